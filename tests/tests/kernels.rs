//! The parallel kernels under mpirun at 1 to 5 ranks.
use tdyn_tests::*;

#[test]
fn comm_plan_delivers_every_item_once_at_1_to_5_ranks() {
    // Random patterns, all-to-one, self-only and a rank sending nothing: each item must arrive
    // once at its destination (counts checked against an MPI all-to-all of what was sent),
    // `reverse` must return each item's own value, and gather + scatter-add must sum exactly.
    for np in 1..=5 {
        for seed in [1u64, 7, 12345] {
            selftest(np, "comm", seed, 120);
        }
    }
}

#[test]
fn rcb_balances_queries_and_rebalances_at_1_to_5_ranks() {
    // Each run checks (see tests/src/bin/tdyn_selftest/rcb.rs): every id owned once against the ids
    // handed in; unit-weight loads within one item; weighted loads within ceil(log2 P) x the
    // largest weight of the mean; each item inside its rank's box; point and box queries equal
    // a brute-force test of every rank's box; identical points, a plane, a line, 0 / 1 / P-1
    // points; a rebalance after a 1 % move migrates under 5 %; a NaN point refused.
    for np in 1..=5 {
        for seed in [3u64, 99] {
            selftest(np, "rcb", seed, 120);
        }
    }
}

#[test]
fn parallel_contact_detection_equals_serial_at_1_to_4_ranks() {
    // tests/src/bin/tdyn_selftest/contact.rs: 400 random moving faces, 200 nodes crossing one of them
    // during the step, 200 flying at random, owners and face holders at random, 3 steps (the
    // later ones start from the previous cuts). The (node, face) pairs and depths found over all
    // ranks equal one serial box holding everything (1e-12 m; the contact crate checks that
    // search against brute force); forces equal the serial push-back (1e-9 relative) and sum
    // to zero (1e-12 of the total).
    for np in 1..=4 {
        for seed in [5u64, 77] {
            selftest(np, "contact", seed, 120);
        }
    }
}

#[test]
fn parallel_sph_equals_serial_and_computes_each_pair_once_at_1_to_4_ranks() {
    // tests/src/bin/tdyn_selftest/sph.rs: 512 jittered particles with random velocities (2 m/s, so
    // they cross rank boundaries), densities (pressures of both signs), smoothing lengths and
    // some fixed ones, gravity, viscosity and tensile correction, 10 steps; LIGGGHTS profile,
    // standard profile, and standard periodic in x and y. Against the sph crate's serial run
    // on the same particles: pairs over all ranks = serial pairs every step (the COI rule
    // computes each pair exactly once), x, v, rho, p within 1e-9 of their scales (round-off),
    // momentum within 1e-12 of sum m|v|.
    for np in 1..=4 {
        selftest(np, "sph", 5, 180);
    }
}
