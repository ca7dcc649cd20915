//! One answer on any CPU, scene by scene (docs/running.md "One answer"): every bundled scene
//! run for a tenth of its end time gives the digest another CPU gave
//! (`tests/reference/scene_digests.txt`, its CPU named there). The reference was not made by
//! this build on this CPU: a CPU, a compiler or a library that changes one bit of one result
//! file of one scene fails here, with the scenes named.
use std::collections::BTreeMap;
use std::process::Command;
use tdyn_tests::*;

/// `scene digest` lines (comments and blank lines skipped) as a map.
fn digests(text: &str) -> BTreeMap<String, String> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (s, d) = l.split_once(' ').expect("a line `scene digest`");
            (s.to_string(), d.trim().to_string())
        })
        .collect()
}

#[test]
fn every_bundled_scene_gives_the_reference_cpus_bits() {
    tdyn(); // the release binary the script runs
    let work = workdir("scene_digests");
    let out = Command::new("bash")
        .arg(root().join("scripts/scene_digests.sh"))
        .env("WORK", &work)
        .env("NP", "1")
        .env("KERNEL", "auto")
        .env("FRACTION", "0.1")
        .env_remove("SCENES")
        .output()
        .expect("bash scripts/scene_digests.sh");
    assert!(
        out.status.success(),
        "scene_digests.sh failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let got = digests(&String::from_utf8_lossy(&out.stdout));
    let reference = std::fs::read_to_string(root().join("tests/reference/scene_digests.txt"))
        .expect("tests/reference/scene_digests.txt");
    let want = digests(&reference);
    let mut wrong = Vec::new();
    for (scene, d) in &got {
        match want.get(scene) {
            Some(w) if w == d => {}
            Some(w) => wrong.push(format!("{scene}: {d} here, {w} in the reference")),
            None => wrong.push(format!("{scene}: {d} here, no reference line")),
        }
    }
    for scene in want.keys().filter(|s| !got.contains_key(*s)) {
        wrong.push(format!("{scene}: in the reference, not run (scene gone?)"));
    }
    assert!(
        wrong.is_empty(),
        "{} of {} scenes differ from tests/reference/scene_digests.txt (other bits on this CPU \
         or build, or a change of results: see that file's header; a failed run's log is in \
         {}):\n{}",
        wrong.len(),
        want.len(),
        work.display(),
        wrong.join("\n")
    );
}
