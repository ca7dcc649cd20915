//! Fuzzing what a user hands the code before any rank computes: the scene parser
//! and the mesh checks.
//!
//! Each scene case takes a valid scene from `scenes/`, applies one to three random mutations
//! (a line deleted, duplicated or swapped, a value replaced by a hostile one, a key renamed, a
//! stray character, the text cut short) and parses it. The contract (docs/scene.md "Exit status"):
//! no panic, only `Ok` or a `SceneError` whose key and message are not empty, on one line.
//! Each mesh case takes a gmsh mesh of a bundled `.geo` (msh 2.2), mutates it the same way (and
//! swaps nodes within an element row, writes hostile numbers into a row) and checks it: no
//! panic, only `Ok` or a one-line message.
//!
//! The tests run `TDYN_FUZZ_CASES` cases (default 10^4). By hand, a long run:
//! `TDYN_FUZZ_CASES=1000000 cargo test --release -p coupling --test fuzz_input -- --nocapture`
//! (`TDYN_FUZZ_SEED` picks another sequence; `TDYN_FUZZ_RECORD=FILE` writes every case's
//! outcome, for comparing two versions of the parser on the same inputs).
use coupling::input::{gmsh, msh_check, scene};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Cases per target when `TDYN_FUZZ_CASES` is not set.
const DEFAULT_CASES: u64 = 10_000;

/// Values a mutation writes in place of a key's value: wrong types, non-finite and absurd
/// magnitudes, wrong lengths, fractions where counts belong.
const HOSTILE_VALUES: &[&str] = &[
    "0",
    "-1",
    "-5",
    "10.5",
    "1e-18",
    "1e-300",
    "1e30",
    "1e12",
    "9.2e18",
    "-9.2e18",
    "nan",
    "inf",
    "-inf",
    "\"x\"",
    "\"7850\"",
    "\"\"",
    "true",
    "[]",
    "[1.0, 2.0]",
    "[1.0, 2.0, 3.0, 4.0]",
    "[nan, 0.0, 0.0]",
    "[\"a\", 1, 2]",
    "{}",
    "{ a = 1 }",
    "{ box = { min = [0.0, 0.0, 0.0], max = [1e30, 1.0, 1.0] } }",
    "{ box = { min = [-9.2e18, 0.0, 0.0], max = [1.0, 1.0, 1.0] } }",
    "1979-05-27",
];

/// Characters a mutation drops into the text (TOML syntax errors).
const STRAY: &[&str] = &[
    "[", "]", "{", "}", "=", "\"", ",", "#", "\n", ".", "0", "a", "'", "\\", "[[", "\u{e9}",
];

/// xorshift64*: a small deterministic generator, so every failure is reproducible by its seed.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in 0..n (n > 0).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

fn cases() -> u64 {
    std::env::var("TDYN_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(DEFAULT_CASES)
}

fn seed() -> u64 {
    std::env::var("TDYN_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(16)
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The valid scenes of `scenes/`: (path, text).
fn seeds() -> Vec<(PathBuf, String)> {
    let mut v: Vec<(PathBuf, String)> = std::fs::read_dir(root().join("scenes"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| {
            let t = std::fs::read_to_string(&p).unwrap();
            (p, t)
        })
        .collect();
    v.sort();
    assert!(v.len() >= 10, "scenes/ should hold the seed scenes");
    for (p, t) in &v {
        if let Err(e) = scene::parse(t, p) {
            panic!("the seed scene {} must parse: {e}", p.display());
        }
    }
    v
}

/// One random mutation of a scene's text.
fn mutate_once(text: &str, rng: &mut Rng, donors: &[(PathBuf, String)]) -> String {
    let mut lines: Vec<String> = text.lines().map(|l| l.to_string()).collect();
    if lines.is_empty() {
        lines.push(String::new());
    }
    let n = lines.len();
    match rng.below(9) {
        0 => {
            lines.remove(rng.below(n));
        }
        1 => {
            let i = rng.below(n);
            let l = lines[i].clone();
            lines.insert(i, l);
        }
        2 => {
            let (i, j) = (rng.below(n), rng.below(n));
            lines.swap(i, j);
        }
        3 | 4 => {
            // A hostile value for a random `key = value` line (the common case).
            let keyed: Vec<usize> = (0..n).filter(|&i| lines[i].contains(" = ")).collect();
            if let Some(&i) = (!keyed.is_empty()).then(|| rng.pick(&keyed)) {
                let key = lines[i].split(" = ").next().unwrap().to_string();
                lines[i] = format!("{key} = {}", rng.pick(HOSTILE_VALUES));
            }
        }
        5 => {
            let keyed: Vec<usize> = (0..n).filter(|&i| lines[i].contains(" = ")).collect();
            if let Some(&i) = (!keyed.is_empty()).then(|| rng.pick(&keyed)) {
                lines[i] = lines[i].replacen(" = ", "x = ", 1);
            }
        }
        6 => {
            // A line from another scene, at a random place (a table or key out of place).
            let (_, d) = rng.pick(donors);
            let dl: Vec<&str> = d.lines().collect();
            if !dl.is_empty() {
                let l = rng.pick(&dl).to_string();
                lines.insert(rng.below(n + 1), l);
            }
        }
        7 => {
            let t = lines.join("\n");
            let mut at = rng.below(t.len() + 1);
            while !t.is_char_boundary(at) {
                at -= 1;
            }
            return format!("{}{}{}", &t[..at], rng.pick(STRAY), &t[at..]);
        }
        _ => {
            let t = lines.join("\n");
            let mut at = rng.below(t.len() + 1);
            while !t.is_char_boundary(at) {
                at -= 1;
            }
            return t[..at].to_string();
        }
    }
    lines.join("\n") + "\n"
}

/// Where a failing case's input is kept (to reproduce it by hand).
fn keep(name: &str, text: &str) -> PathBuf {
    let dir = root().join("target").join("fuzz");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn the_scene_parser_never_panics_and_always_names_a_key() {
    let seeds = seeds();
    let n = cases();
    let mut rng = Rng::new(seed());
    let mut record = std::env::var("TDYN_FUZZ_RECORD")
        .ok()
        .map(|p| std::io::BufWriter::new(std::fs::File::create(p).unwrap()));
    let (mut ok, mut refused) = (0u64, 0u64);
    let t0 = std::time::Instant::now();
    for case in 0..n {
        let (path, text) = rng.pick(&seeds).clone();
        let mut t = text;
        for _ in 0..1 + rng.below(3) {
            t = mutate_once(&t, &mut rng, &seeds);
        }
        let res = std::panic::catch_unwind(|| scene::parse(&t, &path));
        let res = match res {
            Ok(r) => r,
            Err(_) => {
                let p = keep(&format!("scene_panic_{case}.toml"), &t);
                panic!(
                    "case {case}: the parser panicked on {} (a mutation of {})",
                    p.display(),
                    path.display()
                );
            }
        };
        match &res {
            Ok(_) => ok += 1,
            Err(e) => {
                refused += 1;
                // One line, naming a key, saying something.
                let unclear = e.key.trim().is_empty()
                    || e.message.trim().is_empty()
                    || e.to_string().contains('\n');
                if unclear && record.is_none() {
                    let p = keep(&format!("scene_unclear_{case}.toml"), &t);
                    panic!(
                        "case {case}: an error without a key or a message ({e:?}) for {}",
                        p.display()
                    );
                }
            }
        }
        if let Some(w) = record.as_mut() {
            match &res {
                Ok(s) => writeln!(w, "{case} ok {s:?}").unwrap(),
                Err(e) => writeln!(w, "{case} err {e}").unwrap(),
            }
        }
    }
    println!(
        "fuzz scene: {n} cases ({ok} accepted, {refused} refused) in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    assert!(refused > 0, "the mutations should produce refused scenes");
}

/// Tokens a mesh mutation writes into a row: non-finite, absurd and negative numbers, ids no
/// node has, words.
const HOSTILE_TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "0",
    "-1",
    "1e308",
    "-1e308",
    "999999",
    "4294967297",
    "18446744073709551617",
    "2.5",
    "x",
    "$Nodes",
    "$EndElements",
    "",
];

/// Valid msh 2.2 meshes of bundled `.geo` files (gmsh, cached under target/fuzz/meshes).
fn mesh_seeds() -> Vec<String> {
    let cache = root().join("target").join("fuzz").join("meshes");
    let meshes: [(&str, &[(&str, f64)]); 3] = [
        ("bar.geo", &[("N", 4.0), ("M", 2.0)]),
        ("block_plate.geo", &[("NB", 2.0), ("NP", 4.0), ("NH", 1.0)]),
        ("plate.geo", &[("N", 3.0), ("M", 1.0)]),
    ];
    meshes
        .iter()
        .map(|(geo, params)| {
            let def = scene::MeshDef {
                file: root().join("meshes").join(geo),
                params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
                translate: [0.0; 3],
            };
            let msh = gmsh::mesh_file(&def, &cache).expect("gmsh is needed (make setup)");
            let text = std::fs::read_to_string(msh).unwrap();
            msh_check::check(&text)
                .unwrap_or_else(|e| panic!("{geo}: the seed mesh must pass: {e}"));
            text
        })
        .collect()
}

/// One random mutation of a mesh's text.
fn mutate_mesh(text: &str, rng: &mut Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(|l| l.to_string()).collect();
    if lines.is_empty() {
        lines.push(String::new());
    }
    let n = lines.len();
    match rng.below(6) {
        0 => {
            lines.remove(rng.below(n));
        }
        1 => {
            let i = rng.below(n);
            let l = lines[i].clone();
            lines.insert(i, l);
        }
        2 => {
            // Two tokens of one row swapped (an element's nodes reordered: often inverted).
            let i = rng.below(n);
            let mut t: Vec<&str> = lines[i].split(' ').collect();
            let (a, b) = (rng.below(t.len()), rng.below(t.len()));
            t.swap(a, b);
            lines[i] = t.join(" ");
        }
        3 | 4 => {
            let i = rng.below(n);
            let mut t: Vec<String> = lines[i].split(' ').map(String::from).collect();
            let k = rng.below(t.len());
            t[k] = rng.pick(HOSTILE_TOKENS).to_string();
            lines[i] = t.join(" ");
        }
        _ => {
            let t = lines.join("\n");
            return t[..rng.below(t.len() + 1)].to_string();
        }
    }
    lines.join("\n") + "\n"
}

#[test]
fn the_mesh_checks_never_panic_and_always_say_why() {
    let seeds = mesh_seeds();
    let n = cases();
    let mut rng = Rng::new(seed() ^ 0x6d73_6800);
    let (mut ok, mut refused) = (0u64, 0u64);
    let t0 = std::time::Instant::now();
    for case in 0..n {
        let mut t = rng.pick(&seeds).clone();
        for _ in 0..1 + rng.below(3) {
            t = mutate_mesh(&t, &mut rng);
        }
        match std::panic::catch_unwind(|| msh_check::check(&t)) {
            Ok(Ok(_)) => ok += 1,
            Ok(Err(e)) if !e.trim().is_empty() && !e.contains('\n') => refused += 1,
            Ok(Err(e)) => {
                let p = keep(&format!("mesh_unclear_{case}.msh"), &t);
                panic!("case {case}: an unclear message {e:?} for {}", p.display());
            }
            Err(_) => {
                let p = keep(&format!("mesh_panic_{case}.msh"), &t);
                panic!("case {case}: the mesh check panicked on {}", p.display());
            }
        }
    }
    println!(
        "fuzz mesh: {n} cases ({ok} accepted, {refused} refused) in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    assert!(
        refused > 0 && ok > 0,
        "the mutations should give both outcomes"
    );
}
