//! The contact stage in a run: two elastic bars meeting head on.
use tdyn_tests::frames::*;
use tdyn_tests::*;

const L: f64 = 0.1;
const V: f64 = 10.0;

/// c = sqrt(E / rho): Poisson's ratio 0 makes the bar problem exactly 1D.
fn c_bar() -> f64 {
    (200.0e9f64 / 7850.0).sqrt()
}

/// Mass-weighted mean x-velocity of each bar in the last frame of fields.h5 (lumped masses of a
/// uniform 1D mesh: end nodes carry half).
fn bar_velocities(out: &std::path::Path) -> (f64, f64, f64) {
    let f = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut frames = f.group("frames").unwrap().member_names().unwrap();
    frames.sort();
    let mut gap_min = f64::INFINITY;
    let mut last = (0.0, 0.0);
    for fr in &frames {
        let g = f.group(&format!("frames/{fr}")).unwrap();
        let pos: Vec<f64> = g.dataset("nodes/position").unwrap().read_raw().unwrap();
        let disp: Vec<f64> = g.dataset("nodes/displacement").unwrap().read_raw().unwrap();
        let vel: Vec<f64> = g.dataset("nodes/velocity").unwrap().read_raw().unwrap();
        let n = pos.len() / 3;
        let (mut a_max, mut b_min) = (f64::NEG_INFINITY, f64::INFINITY);
        let (mut pa, mut ma, mut pb, mut mb) = (0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let x0 = pos[3 * i] - disp[3 * i];
            let end = x0.abs() < 1e-9 || (x0 - L).abs() < 1e-9 || (x0 - 2.0 * L).abs() < 2e-4;
            let w = if end || (x0 - L).abs() < 2e-4 {
                0.5
            } else {
                1.0
            };
            if x0 < L + 5e-5 {
                a_max = a_max.max(pos[3 * i]);
                pa += w * vel[3 * i];
                ma += w;
            } else {
                b_min = b_min.min(pos[3 * i]);
                pb += w * vel[3 * i];
                mb += w;
            }
        }
        gap_min = gap_min.min(b_min - a_max);
        last = (pa / ma, pb / mb);
    }
    (last.0, last.1, gap_min)
}

#[test]
fn bars_meeting_head_on_exchange_velocities_after_2l_over_c() {
    // scenes/bars_impact.toml: two steel bars (nu = 0), L = 0.1 m, 40 elements each, no bulk viscosity, +-10 m/s,
    // kinematic contact between the facing ends. References: momentum zero (it starts at zero
    // and only internal and contact forces act) to 1e-12 of M v; the 1D elastic impact of
    // equal bars lasts 2L/c and ends with the velocities exchanged (St Venant), within 5 %; the
    // facing ends never overlap by more than 1e-3 of an element (40 elements per 0.1 m) in the
    // frames. At np 1, 2, 3, 4, whose histories agree within 1e-9 of the largest value.
    let dt_el = L / 40.0;
    let mut histories = Vec::new();
    for np in 1..=4 {
        let dir = workdir(&format!("bars_impact_np{np}"));
        let out = dir.join("out");
        run_ok(np, &root().join("scenes/bars_impact.toml"), &out);
        let (h, rows) = read_csv(&out.join("history.csv"));
        let t = column(&h, &rows, "time");
        let dt = column(&h, &rows, "dt");
        let px = column(&h, &rows, "momentum_x");
        let contacts = column(&h, &rows, "contacts");
        let err = column(&h, &rows, "energy_error");
        let mass = 2.0 * 7850.0 * L * 0.01 * 0.01;
        for (k, p) in px.iter().enumerate() {
            assert!(
                p.abs() < 1e-12 * mass * V,
                "np {np}: momentum {p} at t = {} (expected 0 within 1e-12 M v)",
                t[k]
            );
        }
        let steps: Vec<usize> = (0..t.len()).filter(|&k| contacts[k] > 0.0).collect();
        assert!(!steps.is_empty(), "np {np}: the bars never touched");
        let start = t[steps[0]] - dt[steps[0]];
        let end = t[*steps.last().unwrap()];
        let duration = end - start;
        let expect = 2.0 * L / c_bar();
        assert!(
            (duration - expect).abs() < 0.05 * expect,
            "np {np}: contact lasted {duration:e} s, 2L/c = {expect:e} s (5 %)"
        );
        let err_max = err.iter().cloned().fold(0.0, f64::max);
        assert!(
            err_max < 0.05,
            "np {np}: energy error {err_max} (the run's own 5 % limit)"
        );
        let (va, vb, gap) = bar_velocities(&out);
        assert!(
            (va + V).abs() < 0.05 * V && (vb - V).abs() < 0.05 * V,
            "np {np}: mean bar velocities after the impact {va}, {vb}; expected -10, +10 (5 %)"
        );
        assert!(
            gap > -1e-3 * dt_el,
            "np {np}: the bars overlap by {} m in a frame (limit 1e-3 of an element)",
            -gap
        );
        histories.push(rows);
    }
    // The docs/scene.md columns (the contact stage's balance and bytes after them depend on the
    // rank count by nature).
    let physics = 13;
    let scale = histories[0]
        .iter()
        .flat_map(|r| &r[..physics])
        .fold(0.0f64, |a, v| a.max(v.abs()));
    for (k, h) in histories.iter().enumerate().skip(1) {
        for (r0, r) in histories[0].iter().zip(h) {
            for (a, b) in r0[..physics].iter().zip(&r[..physics]) {
                assert!(
                    (a - b).abs() <= 1e-9 * scale,
                    "np {} history differs from np 1: {a} vs {b}",
                    k + 1
                );
            }
        }
    }
}

/// scenes/block_drop.toml: plate 80 x 80 x 10 mm in 16 x 16 x 2 elements, cube of 20 mm in
/// 4^3, both 5 mm elements.
const BLOCK_DROP_H: f64 = 0.005;
/// The plate's thickness, m.
const PLATE_THICKNESS: f64 = 0.01;

#[test]
fn tilted_block_dropped_on_a_plate_never_enters_it() {
    // A steel cube tilted 8 and 5 degrees strikes a free steel plate at (8, 4, -40) m/s, corner
    // first, then slaps down on an edge. References:
    // - geometry: in every frame of fields.h5, no node of the block lies inside the (deformed)
    //   plate (inside one of its elements) deeper than 1e-3 of the element size (5 um) below
    //   the plate's skin. Kinematic push-back
    //   leaves a contacted node on the bilinear face it crossed to round-off (the check measures
    //   against the same bilinear faces, with its own closest-point search). Frames are dense enough that no
    //   node can cross the plate between two of them (asserted: the largest motion between
    //   frames is under half the plate's thickness). The check itself is checked: the last frame
    //   with the block moved down until its lowest node is half an element below z = 0 must show
    //   a block node over a quarter of an element inside the plate.
    // - momentum: nothing holds the bodies and only internal and contact forces act, so each
    //   component stays at its initial value, m_block v, to 1e-12 of |m_block v| (round-off).
    // - energy: kinematic contact only takes energy, so the error of the balance
    //   (kinetic + internal + hourglass + contact energy against the initial kinetic energy) is
    //   small once the bodies separate: under 1e-3 at the end. During contact velocity
    //   Verlet's full-step kinetic energy is off by its O(dt^2 |a|^2) shadow term, largest
    //   while nodes are pushed back; bounded there by the run's own 5 % limit.
    // - rank independence at np 1-4: the contact count of every step is the same, momentum the
    //   same to 1e-12 of its scale and every other column to 1e-9 of its largest value
    //   (round-off of the sums). The push-back of all contacts is solved together
    //   (coupling/src/stages/contact/stage.rs, step 7b); solved box by box, np 3 and 4 differed from np 1 by
    //   1.9e-3 of the contact energy, from the step where four nodes of an edge land at once
    //   in different boxes.
    let mut histories = Vec::new();
    let mass = 7850.0 * 0.02f64.powi(3);
    let v0 = [8.0, 4.0, -40.0];
    let mut header = Vec::new();
    for np in 1..=4 {
        let dir = workdir(&format!("block_drop_np{np}"));
        let out = dir.join("out");
        run_ok(np, &root().join("scenes/block_drop.toml"), &out);
        let (h, rows) = read_csv(&out.join("history.csv"));
        let contacts = column(&h, &rows, "contacts");
        assert!(
            contacts.iter().cloned().fold(0.0, f64::max) >= 3.0,
            "np {np}: the block never landed on an edge (at most {} contacts)",
            contacts.iter().cloned().fold(0.0, f64::max)
        );
        for (c, name) in ["momentum_x", "momentum_y", "momentum_z"]
            .iter()
            .enumerate()
        {
            let p0 = mass * v0[c];
            for p in column(&h, &rows, name) {
                assert!(
                    (p - p0).abs() < 1e-12 * mass * 40.0,
                    "np {np}: {name} = {p}, initially {p0} (1e-12 of m v)"
                );
            }
        }
        let err = column(&h, &rows, "energy_error");
        let err_max = err.iter().cloned().fold(0.0, f64::max);
        assert!(err_max < 0.05, "np {np}: energy error {err_max} (5 %)");
        let err_end = *err.last().unwrap();
        assert!(
            err_end < 1e-3,
            "np {np}: energy error at the end {err_end} (1e-3 once the bodies separated)"
        );
        assert_eq!(
            *contacts.last().unwrap(),
            0.0,
            "np {np}: still in contact at the end"
        );

        // The stage's own figures: one rank sends nothing and is balanced; the report's totals
        // are the history's (a row every step).
        let imbalance = column(&h, &rows, "contact_imbalance");
        let bytes = column(&h, &rows, "contact_bytes");
        assert!(
            imbalance.iter().all(|&i| i >= 1.0 && (np > 1 || i == 1.0)),
            "np {np}: contact imbalance outside [1, P] or not 1 at np 1"
        );
        assert!(
            bytes
                .iter()
                .all(|&b| if np == 1 { b == 0.0 } else { b >= 0.0 })
                && (np == 1 || bytes.iter().any(|&b| b > 0.0)),
            "np {np}: contact bytes (0 at np 1, some at np > 1)"
        );
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        let total: f64 = contacts.iter().sum();
        assert_eq!(
            report["contacts_found_total"].as_f64(),
            Some(total),
            "np {np}: report contacts_found_total against the history's sum"
        );
        assert_eq!(
            report["contact"]["bytes_sent"].as_f64(),
            Some(bytes.iter().sum::<f64>()),
            "np {np}: report contact bytes against the history's sum"
        );
        for key in [
            "contact_share_of_step",
            "contact_imbalance_max",
            "contact_nodes",
        ] {
            assert!(report[key].is_number(), "np {np}: report.json lacks {key}");
        }
        header = h;
        let fr = read_frames(&out);
        let x0 = &fr.positions[0];
        let conn = &fr.connectivity;
        // The plate: elements with every node at or below z = 0; the block's nodes: z > 0.
        let plate = Body::new(
            conn,
            (0..conn.len())
                .filter(|&e| conn[e].iter().all(|&n| x0[n][2] <= 1e-9))
                .collect(),
        );
        let block_nodes: Vec<usize> = (0..x0.len()).filter(|&n| x0[n][2] > 1e-9).collect();
        assert_eq!(plate.elems.len(), 512, "np {np}: plate elements");
        assert_eq!(block_nodes.len(), 125, "np {np}: block nodes");
        let motion = max_frame_motion(&fr);
        assert!(
            motion < 0.5 * PLATE_THICKNESS,
            "np {np}: a node moved {motion} m between frames (must be under half the plate)"
        );
        let tol = 1e-3 * BLOCK_DROP_H;
        let mut deepest = 0.0f64;
        for (k, pos) in fr.positions.iter().enumerate() {
            let (d, n) = deepest_penetration(pos, conn, &block_nodes, &plate);
            deepest = deepest.max(d);
            assert!(
                d < tol,
                "np {np}: block node {n} is {d} m inside the plate at t = {} (limit 1e-3 of the 5 mm element)",
                fr.times[k]
            );
        }
        eprintln!("np {np}: deepest block node inside the plate {deepest:e} m");
        // The check sees a penetration when there is one.
        let mut moved = fr.positions.last().unwrap().clone();
        let lowest = block_nodes
            .iter()
            .fold(f64::INFINITY, |m, &n| m.min(moved[n][2]));
        for &n in &block_nodes {
            moved[n][2] -= lowest + 0.5 * BLOCK_DROP_H;
        }
        let (d, _) = deepest_penetration(&moved, conn, &block_nodes, &plate);
        assert!(
            d > 0.25 * BLOCK_DROP_H,
            "np {np}: the check missed a block corner sunk to half an element below z = 0 ({d} m)"
        );
        if np == 3 {
            // The kept decomposition (contact_stage: skins, candidate lists) served most steps.
            let steps = report["steps"].as_f64().unwrap();
            let rebuilds = report["contact_rebuilds"].as_f64().unwrap();
            assert!(
                rebuilds < 0.5 * steps,
                "np 3: the contact decomposition was rebuilt at {rebuilds} of {steps} steps"
            );
        }
        histories.push(rows);
    }
    // The kept decomposition gives what a rebuild at every step gives: the same history, bit for
    // bit (reference: `--contact-rebuild every-step`, steps 1-6 of Fig. 10 at every step), at
    // np 3.
    let dir = workdir("block_drop_np3_rebuild_every_step");
    let out = dir.join("out");
    let scene = root().join("scenes/block_drop.toml");
    run_ok_args(3, &scene, &out, &["--contact-rebuild", "every-step"]);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(
        report["contact_rebuilds"], report["steps"],
        "--contact-rebuild every-step must rebuild at every step"
    );
    let (_, every) = read_csv(&out.join("history.csv"));
    let d = column_differences(&histories[2], &every);
    for (c, name) in header.iter().enumerate() {
        if matches!(name.as_str(), "contact_bytes" | "contact_imbalance") {
            continue;
        }
        assert!(
            d[c] == 0.0,
            "np 3: history column {name} with the kept decomposition differs from a rebuild at every step by {:e} of its largest value (must be identical)",
            d[c]
        );
    }
    for (k, rows) in histories.iter().enumerate().skip(1) {
        let d = column_differences(&histories[0], rows);
        println!("np {}: largest column differences from np 1: {d:?}", k + 1);
        for (c, name) in header.iter().enumerate() {
            let tol = match name.as_str() {
                // The stage's balance and bytes depend on the rank count by nature.
                "contact_imbalance" | "contact_bytes" => continue,
                "contacts" | "step" => 0.0,
                n if n.starts_with("momentum") => 1e-12,
                _ => 1e-9,
            };
            assert!(
                d[c] <= tol,
                "np {}: history column {name} differs from np 1 by {:e} of its largest value (limit {tol:e})",
                k + 1,
                d[c]
            );
        }
    }
}

/// scenes/tube_crush.toml: the wall thickness, m (one element through it: the smallest element
/// dimension).
const TUBE_WALL: f64 = 0.001;

#[test]
fn crushed_tube_folds_without_its_walls_passing_through_each_other() {
    // A square aluminium tube, one element through its 1 mm wall, crushed 35 mm at 50 m/s with
    // self-contact: the walls fold at the bead and the folds close. References:
    // - geometry: in every frame of fields.h5 (every 5 us), no node of the tube lies inside an
    //   element of the same tube that it is not a corner of deeper than 1e-3 of the wall
    //   thickness (1 um) below the tube's skin (its distance to the nearest boundary face it is
    //   not a corner of). Push-back leaves each contacted node on the face it crossed; what is
    //   left comes from contacts of one face solved in different contact boxes and from the
    //   linearised solve of several contacts on one warped face (contact crate, pushback.rs),
    //   both second order in the step's motion (measured 1e-9 m; 0.32 mm before the search's
    //   parametric tolerance was widened, contact_stage::MESH_PARAM_TOL, which this check
    //   found: nodes on the folds' creases slipping between two faces). Frames are dense enough that no node can cross
    //   a wall between two of them (asserted: the largest motion between frames is under half
    //   the wall). The check itself is checked: a node moved to the centre of a far element is
    //   reported at least a quarter of the wall deep.
    // - the folds do close: contacts are found over at least 500 steps.
    // - energy: the balance (with the work of the driven end as external work) within the
    //   run's 5 % limit throughout and 1e-3 at the end.
    // At np 1 and 3 (the folding is chaotic, so the runs are not compared with each other).
    for np in [1, 3] {
        let dir = workdir(&format!("tube_crush_np{np}"));
        let out = dir.join("out");
        run_ok(np, &root().join("scenes/tube_crush.toml"), &out);
        let (h, rows) = read_csv(&out.join("history.csv"));
        let contacts = column(&h, &rows, "contacts");
        let contact_steps = contacts.iter().filter(|&&c| c > 0.0).count();
        assert!(
            contact_steps >= 500,
            "np {np}: contact in only {contact_steps} steps (the folds did not close)"
        );
        let err = column(&h, &rows, "energy_error");
        let err_max = err.iter().cloned().fold(0.0, f64::max);
        assert!(err_max < 0.05, "np {np}: energy error {err_max} (5 %)");
        let err_end = *err.last().unwrap();
        assert!(
            err_end < 1e-3,
            "np {np}: energy error at the end {err_end} (1e-3)"
        );

        let fr = read_frames(&out);
        let conn = &fr.connectivity;
        let tube = Body::new(conn, (0..conn.len()).collect());
        let mut skin_nodes: Vec<usize> = tube.skin.iter().flatten().cloned().collect();
        skin_nodes.sort_unstable();
        skin_nodes.dedup();
        let motion = max_frame_motion(&fr);
        assert!(
            motion < 0.5 * TUBE_WALL,
            "np {np}: a node moved {motion} m between frames (must be under half the wall)"
        );
        let tol = 1e-3 * TUBE_WALL;
        let mut deepest = 0.0f64;
        for (k, pos) in fr.positions.iter().enumerate() {
            let (d, n) = deepest_penetration(pos, conn, &skin_nodes, &tube);
            deepest = deepest.max(d);
            assert!(
                d < tol,
                "np {np}: tube node {n} is {d} m inside the tube's own wall at t = {} (limit 1e-3 of the 1 mm wall)",
                fr.times[k]
            );
        }
        eprintln!("np {np}: deepest tube node inside its own wall {deepest:e} m, {contact_steps} steps with contact");
        // The check sees a node inside a wall: node 0 moved to the centre of the element
        // farthest from it.
        let mut moved = fr.positions.last().unwrap().clone();
        let centre = |e: usize| -> [f64; 3] {
            std::array::from_fn(|k| conn[e].iter().map(|&i| moved[i][k]).sum::<f64>() / 8.0)
        };
        let far = (0..conn.len())
            .max_by(|&a, &b| {
                let da = sub(centre(a), moved[0]);
                let db = sub(centre(b), moved[0]);
                dot(da, da).total_cmp(&dot(db, db))
            })
            .unwrap();
        moved[0] = centre(far);
        let (d, n) = deepest_penetration(&moved, conn, &skin_nodes, &tube);
        assert!(
            d > 0.25 * TUBE_WALL && n == 0,
            "np {np}: the check missed a node in the middle of a wall ({d} m, node {n})"
        );
    }
}

#[test]
fn static_decomposition_baseline_finds_the_same_contacts() {
    // The benchmark's baseline (contact searched on the FE decomposition,
    // `--contact-decomposition static`)
    // must do the same physics as the dynamic stage for its figures to compare like with like.
    // Reference: the dynamic stage's run of scenes/block_drop.toml at the same rank count. The
    // same contacts are found and their push-back is solved together in both (the dynamic
    // stage's step 7b), so every column of the history but the stage's own balance and bytes
    // is identical, bit for bit (when the baseline solved per box, the contact energy differed
    // by 2.8e-4, and two passes, a touching pair found from both sides in two boxes, pushed
    // apart twice: 1.7e-2 on dt); the report names the decomposition. At np 3.
    let np = 3;
    let dir = workdir("block_drop_baseline");
    let scene = root().join("scenes/block_drop.toml");
    let mut rows = Vec::new();
    for (mode, name) in [("rcb", "dynamic_rcb"), ("static", "static_fe_baseline")] {
        let out = dir.join(format!("out_{mode}"));
        run_ok_args(np, &scene, &out, &["--contact-decomposition", mode]);
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        assert_eq!(report["contact_decomposition"], name);
        rows.push(read_csv(&out.join("history.csv")));
    }
    let (h, dynamic) = &rows[0];
    let (_, baseline) = &rows[1];
    let d = column_differences(dynamic, baseline);
    for (c, name) in h.iter().enumerate() {
        if matches!(name.as_str(), "contact_imbalance" | "contact_bytes") {
            continue;
        }
        assert!(
            d[c] == 0.0,
            "baseline: history column {name} differs from the dynamic stage by {:e} of its largest value (must be identical)",
            d[c]
        );
    }
}

#[test]
fn rcb_balances_the_contact_work_where_the_static_decomposition_cannot() {
    // The benchmark's aim: contact work imbalance (max/mean over ranks of nodes +
    // faces searched) under 1.1 with the dynamic RCB decomposition on a scene where the static FE
    // decomposition exceeds 2. scenes/bricks_pedestal.toml: 64 bricks lifting off a tall
    // column whose top only is a contact surface; METIS cuts the column across its height, so
    // ranks holding its lower part have no contact surface. Reference for "cannot": the
    // baseline's own count at the same rank count (`--contact-decomposition static`), which must exceed
    // 2 at np 4 for the scene to test anything and reach 2 at np 2, the most max/mean can be on
    // two ranks (one rank searches everything; measured 2.000 at np 2, 2.69 at np 4; RCB 1.000).
    // Counts, not times: they do not depend on the machine. A shortened run (30 us).
    let dir = workdir("bricks_pedestal_balance");
    let scene = root().join("scenes/bricks_pedestal.toml");
    for np in [2, 4] {
        let mut imb = Vec::new();
        for mode in ["rcb", "static"] {
            let out = dir.join(format!("np{np}_{mode}"));
            run_ok_args(
                np,
                &scene,
                &out,
                &["--contact-decomposition", mode, "--end-time", "3e-5"],
            );
            let report: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                    .unwrap();
            imb.push(report["contact_imbalance_max"].as_f64().unwrap());
        }
        eprintln!(
            "np {np}: contact imbalance (worst step) RCB {:.3}, static baseline {:.3}",
            imb[0], imb[1]
        );
        let least = if np == 2 { 2.0 - 1e-9 } else { 2.0 + 1e-9 };
        assert!(
            imb[1] >= least,
            "np {np}: the static baseline's imbalance {} is under {least}: the scene no longer tests the aim",
            imb[1]
        );
        assert!(
            imb[0] < 1.1,
            "np {np}: the dynamic RCB's contact imbalance {} (aim: under 1.1)",
            imb[0]
        );
    }
}

/// scenes/block_flat_drop.toml: plate and cube both in 5 mm elements.
const FLAT_DROP_H: f64 = 0.005;
/// The cube's momentum, kg m/s: 7850 kg/m^3 x (0.02 m)^3 x 40 m/s, downward.
const FLAT_DROP_P: f64 = -7850.0 * 0.02 * 0.02 * 0.02 * 40.0;

/// The alignments of `block_flat_drop`'s meshes: (name, DX, DY). The cube's lower nodes over
/// the plate's nodes, over the middles of its edges, over its face centres, and anywhere.
const ALIGNMENTS: [(&str, f64, f64); 4] = [
    ("node_over_node", 0.0, 0.0),
    ("node_over_edge", 0.0025, 0.0),
    ("node_over_face", 0.0025, 0.0025),
    ("offset", 0.0017, 0.0011),
];

/// Runs `block_flat_drop` at `np` with the cube shifted (dx, dy), meshed first if `block_first`,
/// returns the output directory.
fn flat_drop(np: usize, tag: &str, (dx, dy): (f64, f64), block_first: bool) -> std::path::PathBuf {
    let out = workdir(&format!("block_flat_drop_{tag}_np{np}")).join("out");
    let (dx, dy) = (format!("DX={dx}"), format!("DY={dy}"));
    let bf = format!("BLOCK_FIRST={}", block_first as u8);
    run_ok_args(
        np,
        &root().join("scenes/block_flat_drop.toml"),
        &out,
        &["-p", &dx, "-p", &dy, "-p", &bf],
    );
    out
}

/// The cube's top at the end of a run: the probe `block_top`'s z-displacement, m.
fn top_displacement(out: &std::path::Path) -> f64 {
    let (h, rows) = read_csv(&out.join("probes.csv"));
    *column(&h, &rows, "block_top.displacement_z")
        .last()
        .unwrap()
}

#[test]
fn flat_block_on_a_plate_never_lets_a_node_through_whatever_the_alignment() {
    // Issue 15: a node landing on a node of the other surface went through it (the dead zone of
    // the closest-point projection behind the dimple it makes; contact crate, `pair`). A steel
    // cube dropped flat at 40 m/s onto a free steel plate, both in 5 mm elements, its lower
    // nodes over the plate's nodes, over the middles of its edges, over its face centres, and
    // anywhere (scenes/block_flat_drop.toml, -p DX, DY), at np 1, 2 and 3. References:
    // - geometry (non-penetration): in every frame of fields.h5 (every 2.5 us), no surface node
    //   of either body lies inside the other body deeper than 1e-3 of the 5 mm element (5 um;
    //   the issue asks for 1 %), measured with the tests' own projection (tdyn_tests::frames).
    //   Measured 5.7e-9 m node over node, 1.5e-11 m over an edge, 1e-17 m elsewhere; before the
    //   fix 95 um (node over node), 75 um (over an edge) and 6 um (anywhere), one-pass. Frames are dense enough that no node crosses the plate between
    //   two (asserted: the largest motion between frames is under half the plate).
    // - momentum: nothing holds the bodies, so it stays the cube's initial m v to 1e-12 of it.
    // - rank independence: every frame's node and element values in fields.h5 the same bits at
    //   np 1, 2, 3 (docs/scene.md "One answer"), and so the contact count and step of every row;
    //   the history's energy sums (reduced in rank order) within 1e-10 of their largest value.
    // The check itself is checked: the last frame with the cube moved down until its lowest
    // node is half an element below the plate's top shows a node over a quarter element deep.
    for (name, dx, dy) in ALIGNMENTS {
        let mut histories = Vec::new();
        let mut header = Vec::new();
        let mut first = None;
        for np in 1..=3 {
            let out = flat_drop(np, name, (dx, dy), false);
            let base = first.get_or_insert_with(|| out.clone());
            if let Err(e) = fields_differ(base, &out) {
                panic!("{name} np {np} against np 1: fields.h5 {e} (the same bits expected)");
            }
            let (h, rows) = read_csv(&out.join("history.csv"));
            let contacts = column(&h, &rows, "contacts");
            assert!(
                contacts.iter().cloned().fold(0.0, f64::max) >= 16.0,
                "{name} np {np}: the cube never landed flat"
            );
            for (c, col) in ["momentum_x", "momentum_y", "momentum_z"]
                .iter()
                .enumerate()
            {
                let p0 = if c == 2 { FLAT_DROP_P } else { 0.0 };
                for p in column(&h, &rows, col) {
                    assert!(
                        (p - p0).abs() <= 1e-12 * FLAT_DROP_P.abs(),
                        "{name} np {np}: {col} = {p}, initially {p0} (1e-12 of m v)"
                    );
                }
            }
            let fr = read_frames(&out);
            let bodies = bodies(&fr.connectivity);
            assert_eq!(bodies.len(), 2, "{name}: two bodies");
            assert!(max_frame_motion(&fr) < 0.5 * PLATE_THICKNESS);
            let deepest = deepest_over_frames(&fr, &bodies);
            eprintln!(
                "{name} np {np}: deepest node inside the other body {:.3e} m (t = {:.3e}, node {})",
                deepest.0, deepest.1, deepest.2
            );
            assert!(
                deepest.0 < 1e-3 * FLAT_DROP_H,
                "{name} np {np}: node {} is {} m inside the other body at t = {} (limit 1e-3 of the 5 mm element)",
                deepest.2,
                deepest.0,
                deepest.1
            );
            if np == 1 && name == "node_over_node" {
                let x0 = &fr.positions[0];
                let mut moved = fr.positions.last().unwrap().clone();
                let cube: Vec<usize> = (0..x0.len()).filter(|&n| x0[n][2] > 1e-9).collect();
                let lowest = cube.iter().fold(f64::INFINITY, |m, &n| m.min(moved[n][2]));
                for &n in &cube {
                    moved[n][2] -= lowest + 0.5 * FLAT_DROP_H;
                }
                let (d, _) = deepest_between_bodies(&moved, &fr.connectivity, &bodies);
                assert!(
                    d > 0.25 * FLAT_DROP_H,
                    "the check missed the cube sunk half an element into the plate ({d} m)"
                );
            }
            header = h;
            histories.push(rows);
        }
        for (k, rows) in histories.iter().enumerate().skip(1) {
            let d = column_differences(&histories[0], rows);
            for (c, col) in header.iter().enumerate() {
                let tol = match col.as_str() {
                    // The balance and bytes depend on the rank count by nature; momentum was
                    // checked against m v above (x and y are round-off around 0, so relative
                    // to their own largest value they differ at any order).
                    "contact_imbalance" | "contact_bytes" => continue,
                    n if n.starts_with("momentum") => continue,
                    "contacts" | "step" => 0.0,
                    _ => 1e-10,
                };
                assert!(
                    d[c] <= tol,
                    "{name} np {}: history column {col} differs from np 1 by {:e} of its largest value (limit {tol:e})",
                    k + 1,
                    d[c]
                );
            }
        }
    }
}

#[test]
fn the_order_of_the_bodies_in_the_mesh_does_not_change_the_answer() {
    // Issue 15: with the one-pass search the later body's nodes were searched against the
    // earlier body's faces, so meshing the other body first changed the answer (a ball meshed
    // before its plate sank 2 mm into it). Two passes (the default) search both ways.
    // Reference: the same run with the cube meshed second; meshed first (-p BLOCK_FIRST=1: its
    // elements, nodes and body number come first), the final z-displacement of the cube's top
    // differs by under 1 % (measured under 1e-5, and 1.3 %, 0.4 %, 0.8 % and
    // 0.4 % one-pass before, aligned to offset), for each alignment, at np 2. Then one pass,
    // explicitly (`passes = 1`, `master = ["plate"]`): the report says so and the cube's nodes
    // are still kept out of the plate (5 um, as above).
    for (name, dx, dy) in ALIGNMENTS {
        let second = top_displacement(&flat_drop(2, &format!("{name}_order0"), (dx, dy), false));
        let first = top_displacement(&flat_drop(2, &format!("{name}_order1"), (dx, dy), true));
        let rel = (first - second).abs() / second.abs();
        eprintln!("{name}: top displacement {second:.6e} m (plate first), {first:.6e} m (cube first): {rel:.2e}");
        assert!(
            second < -1e-4,
            "{name}: the cube's top moved {second} m (it must land and press the plate)"
        );
        assert!(
            rel < 0.01,
            "{name}: the cube's top moved {second} m with the plate meshed first, {first} m with the cube first ({rel:.3e}, limit 1 %)"
        );
    }
    let dir = workdir("block_flat_drop_one_pass");
    let text = std::fs::read_to_string(root().join("scenes/block_flat_drop.toml"))
        .unwrap()
        .replace(
            "\"../meshes/block_flat.geo\"",
            &format!("\"{}\"", root().join("meshes/block_flat.geo").display()),
        )
        .replace(
            "surfaces = [\"block_skin\", \"plate_top\"]",
            "surfaces = [\"block_skin\", \"plate_top\"]\npasses = 1\nmaster = [\"plate\"]",
        );
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let out = dir.join("out");
    run_ok(2, &scene, &out);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["contact_passes"], 1);
    assert_eq!(report["contact_master_bodies"], 1);
    let fr = read_frames(&out);
    let x0 = &fr.positions[0];
    let conn = &fr.connectivity;
    let plate = Body::new(
        conn,
        (0..conn.len())
            .filter(|&e| conn[e].iter().all(|&n| x0[n][2] <= 1e-9))
            .collect(),
    );
    let cube: Vec<usize> = (0..x0.len()).filter(|&n| x0[n][2] > 1e-9).collect();
    for (k, pos) in fr.positions.iter().enumerate() {
        let (d, n) = deepest_penetration(pos, conn, &cube, &plate);
        assert!(
            d < 1e-3 * FLAT_DROP_H,
            "one pass: cube node {n} is {d} m inside the plate at t = {}",
            fr.times[k]
        );
    }
}

/// Runs `scenes/ball_plate.toml` at `np` with the plate in `np_plate` x `np_plate` elements,
/// the ball meshed first if `ball_first`; returns the output directory.
fn ball_on_plate(np: usize, np_plate: usize, ball_first: bool) -> std::path::PathBuf {
    let out = workdir(&format!(
        "ball_plate_np_plate{np_plate}_first{}_np{np}",
        ball_first as u8
    ))
    .join("out");
    let (n, bf) = (
        format!("NP={np_plate}"),
        format!("BALL_FIRST={}", ball_first as u8),
    );
    run_ok_args(
        np,
        &root().join("scenes/ball_plate.toml"),
        &out,
        &["-p", &n, "-p", &bf],
    );
    out
}

#[test]
fn ball_on_a_clamped_plate_stays_out_of_it_with_or_without_a_node_under_its_pole() {
    // Issue 15's case: a steel ball (5 mm radius, hex O-grid) strikes a clamped 4 mm plate at
    // 200 m/s (scenes/ball_plate.toml, 20 us). With the plate in 12 x 12 elements a plate node
    // lies right under the ball's pole node (to 1e-11 m); with 13 x 13 a face centre does. The
    // ball's faces meet the plate at every angle. References:
    // - geometry (non-penetration): in every frame (every 1 us; the ball moves 0.2 mm, under
    //   half the plate, between two), no surface node of either body inside the other deeper
    //   than 1e-3 of the plate's element (2.5 um at 12 x 12; the issue asks for 1 %): measured
    //   2.8e-7 m and 6e-19 m; before the fix 0.53 mm (node under the pole) and, with the ball
    //   meshed first (one pass: the plate's nodes against the ball's faces), 1.95 mm and 0.43 mm.
    // - energy: the balance (the work of the clamped sides as external work) within the run's
    //   own 5 % throughout (velocity Verlet's full-step kinetic energy carries its O(dt^2 |a|^2)
    //   term while nodes are pushed back: measured 2.5e-3) and 1e-3 at the end (8.5e-5).
    // - rank independence at np 1, 2, 3: the contact count of every step the same, every other
    //   column of history.csv within 1e-10 of its largest value.
    // - mesh order: the ball meshed first (-p BALL_FIRST=1) moves its top to within 1 % of the
    //   same run with the plate first (measured 6e-12; 120 % before, the ball sunk 2 mm).
    // - the report's counts: the contacts by pass add up to contacts_found_total, are the same
    //   at every rank count (the contacts are), both passes find contacts where a node meets a
    //   node (NP 12; over a face centre the flat plate's nodes never enter the ball), and no
    //   contact is coupled across boxes on one rank.
    let kinds = [
        "contacts_later_on_earlier_total",
        "contacts_earlier_on_later_total",
        "contacts_self_total",
        "contacts_particle_total",
    ];
    for np_plate in [12, 13] {
        let element = 0.03 / np_plate as f64;
        let mut histories = Vec::new();
        let mut header = Vec::new();
        let mut counts_np1 = Vec::new();
        for np in 1..=3 {
            let out = ball_on_plate(np, np_plate, false);
            let report: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                    .unwrap();
            let count = |k: &str| {
                report[k]
                    .as_u64()
                    .unwrap_or_else(|| panic!("report lacks {k}"))
            };
            let by_kind: Vec<u64> = kinds.iter().map(|k| count(k)).collect();
            assert_eq!(
                by_kind.iter().sum::<u64>(),
                count("contacts_found_total"),
                "NP {np_plate} np {np}: contacts by pass {by_kind:?} do not add up"
            );
            // Node on node (NP 12), the gap is found both ways; over a face centre only the
            // ball's nodes cross the flat plate's faces.
            assert!(
                by_kind[0] > 0 && (by_kind[1] > 0) == (np_plate == 12),
                "NP {np_plate} np {np}: contacts by pass {by_kind:?}"
            );
            if np == 1 {
                assert_eq!(count("contacts_coupled_across_boxes_total"), 0);
                counts_np1 = by_kind;
            } else {
                assert_eq!(
                    by_kind, counts_np1,
                    "NP {np_plate} np {np}: contacts by pass"
                );
            }
            let (h, rows) = read_csv(&out.join("history.csv"));
            let contacts = column(&h, &rows, "contacts");
            assert!(
                contacts.iter().any(|&c| c > 0.0),
                "NP {np_plate} np {np}: the ball never touched the plate"
            );
            let err = column(&h, &rows, "energy_error");
            let err_max = err.iter().cloned().fold(0.0, f64::max);
            let err_end = *err.last().unwrap();
            assert!(
                err_max < 0.05 && err_end < 1e-3,
                "NP {np_plate} np {np}: energy error {err_max} at most (5 %), {err_end} at the end (1e-3)"
            );
            let fr = read_frames(&out);
            let bodies = bodies(&fr.connectivity);
            assert_eq!(bodies.len(), 2);
            assert!(max_frame_motion(&fr) < 0.5 * 0.004);
            let deepest = deepest_over_frames(&fr, &bodies);
            eprintln!(
                "ball, plate {np_plate}^2, np {np}: deepest node inside the other body {:.3e} m (t = {:.3e}), energy error {err_max:.2e} at most, {err_end:.2e} at the end",
                deepest.0, deepest.1
            );
            assert!(
                deepest.0 < 1e-3 * element,
                "NP {np_plate} np {np}: node {} is {} m inside the other body at t = {} (limit 1e-3 of the plate's {element} m element)",
                deepest.2,
                deepest.0,
                deepest.1
            );
            header = h;
            histories.push(rows);
        }
        for (k, rows) in histories.iter().enumerate().skip(1) {
            let d = column_differences(&histories[0], rows);
            for (c, col) in header.iter().enumerate() {
                let tol = match col.as_str() {
                    "contact_imbalance" | "contact_bytes" => continue,
                    // Round-off around 0: relative to its own largest value, any order.
                    "momentum_x" | "momentum_y" => continue,
                    "contacts" | "step" => 0.0,
                    _ => 1e-10,
                };
                assert!(
                    d[c] <= tol,
                    "NP {np_plate} np {}: history column {col} differs from np 1 by {:e} of its largest value (limit {tol:e})",
                    k + 1,
                    d[c]
                );
            }
        }
        let top = |out: &std::path::Path| {
            let (h, rows) = read_csv(&out.join("probes.csv"));
            *column(&h, &rows, "ball_top.displacement_z").last().unwrap()
        };
        let second = top(&ball_on_plate(2, np_plate, false));
        let first = top(&ball_on_plate(2, np_plate, true));
        let rel = (first - second).abs() / second.abs();
        eprintln!("ball, plate {np_plate}^2: top displacement {second:.6e} m (plate first), {first:.6e} m (ball first): {rel:.2e}");
        assert!(
            rel < 0.01,
            "NP {np_plate}: the ball's top moved {second} m with the plate meshed first, {first} m with the ball first ({rel:.3e}, limit 1 %)"
        );
    }
}

/// The checker by hand, on any run's output (two or more bodies): the deepest surface node of one
/// body inside another, per frame. `TDYN_OUT=DIR cargo test --release -p tdyn-tests --test
/// contact penetration_of_a_run -- --ignored --nocapture`.
#[test]
#[ignore]
fn penetration_of_a_run() {
    let out = std::path::PathBuf::from(std::env::var("TDYN_OUT").unwrap());
    let fr = read_frames(&out);
    let bodies = bodies(&fr.connectivity);
    let mut worst = (0.0f64, 0.0f64, usize::MAX);
    for (k, pos) in fr.positions.iter().enumerate() {
        let (d, n) = deepest_between_bodies(pos, &fr.connectivity, &bodies);
        if d > 0.0 {
            eprintln!("t = {:.4e}: node {n} {d:.3e} m deep", fr.times[k]);
        }
        if d > worst.0 {
            worst = (d, fr.times[k], n);
        }
    }
    eprintln!(
        "deepest {:.3e} m at t = {:.4e} (node {})",
        worst.0, worst.1, worst.2
    );
}

/// The block's slope of velocity_x over time (least squares over the last 80 % of the rows).
fn fitted_acceleration(out: &std::path::Path) -> (f64, f64, f64) {
    let (h, rows) = read_csv(&out.join("probes.csv"));
    let t = column(&h, &rows, "time");
    let v = column(&h, &rows, "block.velocity_x");
    let d = column(&h, &rows, "block.displacement_x");
    let k0 = t.len() / 5;
    let (ts, vs) = (&t[k0..], &v[k0..]);
    let n = ts.len() as f64;
    let (mt, mv) = (ts.iter().sum::<f64>() / n, vs.iter().sum::<f64>() / n);
    let num: f64 = ts.iter().zip(vs).map(|(x, y)| (x - mt) * (y - mv)).sum();
    let den: f64 = ts.iter().map(|x| (x - mt) * (x - mt)).sum();
    (num / den, *v.last().unwrap(), *d.last().unwrap())
}

#[test]
fn block_on_an_incline_slides_at_g_sin_minus_mu_cos_and_sticks_above_tan() {
    // scenes/incline_friction.toml: gravity 9.81 m/s^2 tilted 30 degrees from the plate's
    // normal. Coulomb (one coefficient, static = kinetic): a = g (sin 30 - mu cos 30), within
    // 1 %, for mu = 0 (4.905 m/s^2) and 0.3 (2.356 m/s^2); for mu = 0.7 > tan 30 the block
    // stays (its velocity under 1 % of the frictionless one at the end). The energy balance
    // closes with the friction work in contact_energy (max_energy_error 5 %, the default,
    // and energy_error at the end under 1e-4). At np 1 and 3.
    let g = 9.81;
    let (s, c) = (0.5f64, 3f64.sqrt() / 2.0);
    let dir = workdir("incline_friction");
    let text = std::fs::read_to_string(root().join("scenes/incline_friction.toml"))
        .unwrap()
        .replace("\"../meshes/", &format!("\"{}/meshes/", root().display()));
    let mut v_free = 0.0;
    for mu in [0.0, 0.3, 0.7] {
        for np in [1, 3] {
            let scene = dir.join(format!("incline_{mu}.toml"));
            std::fs::write(
                &scene,
                text.replace("friction = 0.3", &format!("friction = {mu}")),
            )
            .unwrap();
            let out = dir.join(format!("mu{mu}_np{np}"));
            run_ok(np, &scene, &out);
            let (a, v_end, _) = fitted_acceleration(&out);
            let (hh, hist) = read_csv(&out.join("history.csv"));
            let err = *column(&hh, &hist, "energy_error").last().unwrap();
            assert!(err < 1e-4, "mu {mu} np {np}: energy error {err:e} (1e-4)");
            let expected = g * (s - mu * c);
            if expected > 0.0 {
                assert!(
                    (a - expected).abs() < 0.01 * expected,
                    "mu {mu} np {np}: a = {a} m/s^2, g (sin - mu cos) = {expected} (1 %)"
                );
                if mu == 0.0 {
                    v_free = v_end;
                }
            } else {
                assert!(
                    v_end.abs() < 0.01 * v_free,
                    "mu {mu} np {np}: stays (velocity {v_end} m/s against {v_free} without friction)"
                );
            }
        }
    }
}

/// `scenes/cloud_on_plate.toml` grown along x for `np` ranks, as `scripts/scaling_contact.sh`
/// grows it: a 0.1 np m plate of 10 np x 10 x 2 hexahedra under a water cloud 0.1 np - 0.01 m
/// long, the same contacts per rank at every np.
fn cloud_strip(dir: &std::path::Path, np: usize) -> std::path::PathBuf {
    let text = std::fs::read_to_string(root().join("scenes/cloud_on_plate.toml")).unwrap();
    let x1 = 0.05 * np as f64 - 0.005;
    let swaps = [
        (
            "file = \"../meshes/plate.geo\"".to_string(),
            format!("file = \"{}\"", root().join("meshes/plate.geo").display()),
        ),
        (
            "params = { L = 0.1, T = 0.01, N = 10, M = 2 }".to_string(),
            format!(
                "params = {{ L = 0.1, LX = {}, NX = {}, T = 0.01, N = 10, M = 2 }}",
                0.1 * np as f64,
                10 * np
            ),
        ),
        (
            "min = [-0.03, -0.03, 0.0005], max = [0.03, 0.03, 0.0305]".to_string(),
            format!("min = [-{x1}, -0.03, 0.0005], max = [{x1}, 0.03, 0.0305]"),
        ),
    ];
    let mut s = text;
    for (a, b) in &swaps {
        assert!(
            s.contains(a.as_str()),
            "scenes/cloud_on_plate.toml has no `{a}`"
        );
        s = s.replace(a.as_str(), b);
    }
    let path = dir.join(format!("cloud_strip_np{np}.toml"));
    std::fs::write(&path, s).unwrap();
    path
}

#[test]
fn the_push_back_sends_what_its_cells_share_not_every_contact() {
    // Issue 15 item 3: the push-back is solved in cells where the contacts are, and ranks
    // exchange only the nodes their cells share. A water cloud falling on a plate, grown along
    // x with the rank count (the same particle contacts per rank per step), at np 3 and 4,
    // 0.15 ms (contact from about 50 us). References (counts, not times):
    // - what the push-back replaced: every contact (a 664-byte packet) gathered on every rank,
    //   664 (P - 1) x contacts per step bytes received per rank; the busiest rank's push-back
    //   bytes per step must stay under a quarter of that (measured 1/30 at np 3, 1/53 at np 4);
    // - weak scaling: per rank, the mean push-back bytes and the contacts the busiest rank
    //   solves per step within 1.5 times between np 3 and np 4 (measured 1.37 and 1.13: np 4
    //   has two inner strips to np 3's one; scripts/scaling_contact.sh measured 1.25 and 1.05
    //   times from np 4 to 32); a gather would grow as P.
    let dir = workdir("pushback_weak");
    let mut per_rank = Vec::new();
    for np in [3usize, 4] {
        let scene = cloud_strip(&dir, np);
        let out = dir.join(format!("np{np}"));
        run_ok_args(np, &scene, &out, &["--end-time", "1.5e-4"]);
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        let f = |k: &str| r[k].as_f64().unwrap_or_else(|| panic!("report lacks {k}"));
        let steps = f("steps");
        let contacts = f("contacts_found_total") / steps;
        assert!(
            contacts > 20.0 * np as f64,
            "np {np}: the cloud is on the plate ({contacts:.0} contacts a step)"
        );
        let gather = 664.0 * (np as f64 - 1.0) * contacts;
        let busiest = f("contact_pushback_bytes_per_rank_step_max");
        assert!(
            busiest < 0.25 * gather,
            "np {np}: the busiest rank's push-back sends {busiest:.0} B a step, under a quarter of the {gather:.0} B a gather of every contact would bring it"
        );
        per_rank.push((
            f("contact_pushback_bytes_per_step") / np as f64,
            f("contact_pushback_rows_per_rank_step_max"),
        ));
    }
    let (a, b) = (per_rank[0], per_rank[1]);
    assert!(
        b.0 <= 1.5 * a.0 && b.1 <= 1.5 * a.1,
        "weak scaling np 3 -> 4: push-back bytes per rank {:.0} -> {:.0} B a step, the busiest rank's contacts {:.0} -> {:.0}: within 1.5 times",
        a.0,
        b.0,
        a.1,
        b.1
    );
}

#[test]
fn a_round_tube_folding_onto_its_driven_end_never_has_contact_give_energy_back() {
    // docs/scene.md `[contact]`: contact never gives energy back. A round aluminium tube
    // (meshes/round_tube.geo: R 15 mm, wall 1 mm with two hexahedra through it, 60 mm), its
    // bottom fixed and its top driven down at 30 m/s by a `velocity` boundary, self-contact on
    // every exterior face. From 0.43 ms its inner surface folds onto the faces of the driven
    // top ring: the driven corners push the free nodes, and the push-back's work on them (at
    // the prescribed velocity) is the boundary's. Booked on the free nodes alone,
    // contact_energy fell to -8.55 J (S about 164 J) and the energy guard scaled the forces
    // in 203 steps. Reference: the conservation law's bookkeeping (`run_ok` holds every row's
    // fall of contact_energy under 1e-3 of S; measured 1e-7), no step's forces scaled
    // (report.json contact_energy_limited_steps, measured 0), contact_energy >= 0, np 3 the
    // same bytes as np 1.
    let dir = workdir("round_tube_driven_fold");
    let text = format!(
        "[run]\nend_time = 6.0e-4\nhistory_every = 2.0e-6\n\n\
         [[mesh]]\nfile = \"{}\"\n\n\
         [[material]]\nname = \"al\"\nmodel = \"j2_plastic\"\ndensity = 2700.0\nyoungs_modulus = 70.0e9\n\
         poisson_ratio = 0.3\nyield_stress = 150.0e6\nhardening_modulus = 300.0e6\n\n\
         [[block]]\ngroup = \"tube\"\nmaterial = \"al\"\n\n\
         [[boundary]]\ngroup = \"bottom\"\nkind = \"fixed\"\n\n\
         [[boundary]]\ngroup = \"top\"\nkind = \"velocity\"\nvelocity = [0.0, 0.0, -30.0]\n\n\
         [contact]\nsurfaces = [\"exterior\"]\nself_contact = true\n",
        root().join("meshes/round_tube.geo").display()
    );
    let scene = dir.join("tube.toml");
    std::fs::write(&scene, text).unwrap();
    let mut outs = Vec::new();
    for np in [1, 3] {
        let out = dir.join(format!("np{np}"));
        run_ok(np, &scene, &out);
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        assert_eq!(
            report["contact_energy_limited_steps"].as_u64(),
            Some(0),
            "np {np}: no step's contact forces scaled by the energy guard"
        );
        let (h, rows) = read_csv(&out.join("history.csv"));
        let ce = column(&h, &rows, "contact_energy");
        let contacts = column(&h, &rows, "contacts");
        assert!(
            contacts.iter().any(|&c| c > 0.0),
            "np {np}: the folds touch"
        );
        let low = ce.iter().copied().fold(f64::MAX, f64::min);
        assert!(
            low >= 0.0,
            "np {np}: contact_energy reaches {low:e} J (>= 0)"
        );
        outs.push(out);
    }
    for file in ["history.csv", "probes.csv"] {
        let bad = csv_columns_differ(
            &outs[0],
            &outs[1],
            file,
            &["contact_imbalance", "contact_bytes"],
        );
        assert!(bad.is_empty(), "np 3 against np 1: {file} differs: {bad:?}");
    }
}

#[test]
fn a_thin_plate_landing_flat_on_a_plate_runs_to_its_end_with_its_energy() {
    // A 40 x 40 x 1 mm steel plate, one hexahedron through its thickness, landing flat at
    // 20 m/s on a free 40 x 40 x 10 mm plate (meshes/block_flat.geo with T and NT), default
    // settings. Where the pressed nodes are much of a light body, their closing half-kick into
    // each other (docs/scene.md, `[contact]`) counts in the energy error for a few steps at the
    // impact (measured 11 % for 3 steps); the check stops a run only past max_energy_error for
    // 20 steps in a row or ten times past it (docs/scene.md, `max_energy_error`), so the run
    // reaches its end. References:
    // - energy conservation: the error at the end within 1 % (measured 0.14 %; contact's
    //   push-back work is booked in contact_energy), and never past 10 x max_energy_error;
    // - momentum conservation (no supports, no gravity): the total z-momentum of every row
    //   equals the start's, -0.2512 kg m/s (7850 x 0.04^2 x 0.001 x 20), to 1e-12 of it;
    // - one answer: np 1 and np 3 write the same bytes.
    let dir = workdir("thin_plate_landing");
    let text = format!(
        "title = \"thin plate landing flat\"\n[run]\nend_time = 6.0e-5\n[[mesh]]\nfile = \"{}\"\nparams = {{ A = 0.04, NB = 10, T = 0.001, NT = 1, W = 0.04, H = 0.01, NP = 10, NH = 2, G = 0.0005 }}\n[[material]]\nname = \"steel\"\nmodel = \"elastic\"\ndensity = 7850.0\nyoungs_modulus = 200.0e9\npoisson_ratio = 0.3\n[[block]]\ngroup = \"plate\"\nmaterial = \"steel\"\n[[block]]\ngroup = \"block\"\nmaterial = \"steel\"\nvelocity = [0.0, 0.0, -20.0]\n[contact]\nsurfaces = [\"block_skin\", \"plate_top\"]\n",
        root().join("meshes/block_flat.geo").display()
    );
    let scene = dir.join("thin.toml");
    std::fs::write(&scene, text).unwrap();
    let out = run_np1_np3_same_bytes(&scene, &dir);
    let (h, rows) = read_csv(&out.join("history.csv"));
    let err = column(&h, &rows, "energy_error");
    let contacts = column(&h, &rows, "contacts");
    assert!(
        contacts.iter().any(|&c| c > 0.0),
        "the plates meet within the run"
    );
    let last = *err.last().unwrap();
    let largest = err.iter().cloned().fold(0.0, f64::max);
    println!(
        "thin plate landing: energy error at the end {last:.3e}, largest {largest:.3e}, steps past 5 %: {}",
        err.iter().filter(|&&e| e > 0.05).count()
    );
    assert!(
        last < 0.01,
        "energy error at the end {last:e} (energy conservation, 1 %)"
    );
    assert!(
        largest < 0.5,
        "energy error {largest:e} never ten times past max_energy_error (0.05)"
    );
    let p0 = -7850.0 * 0.04 * 0.04 * 0.001 * 20.0;
    for (k, p) in column(&h, &rows, "momentum_z").iter().enumerate() {
        assert!(
            (p - p0).abs() <= 1e-12 * p0.abs(),
            "row {k}: z-momentum {p} against {p0} (no supports: conserved, 1e-12)"
        );
    }
}
