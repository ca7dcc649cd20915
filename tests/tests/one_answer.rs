//! One answer at any rank count (SCENE.md "One answer"): the same bits, not the same to a
//! tolerance. The reference is the run on one rank; the property is exact equality, which no
//! tolerance can hide.
use tdyn_tests::*;

/// `scenes/block_drop.toml` (a tilted steel block dropped at 40 m/s onto a plate: FE on METIS
/// partitions, contact on its own RCB decomposition) at np 1 to 4: every frame's node and
/// element values in fields.h5 (matched by id) and every probe value are the same bits as at
/// np 1, and so is every history.csv column but the run's own measurements `contact_imbalance`
/// and `contact_bytes` (energies, per-block energies, momenta, energy error). Each node's force
/// is summed in canonical element order over all ranks holding it (`fe_petsc::assembly`);
/// contact, given the same nodes, finds and solves the same contacts; every energy and
/// momentum sum is exact on fixed grids (`fe_petsc::exact`).
#[test]
fn fe_and_contact_fields_are_the_same_bits_at_1_to_4_ranks() {
    let scene = root().join("scenes/block_drop.toml");
    let base = workdir("one_answer_np1").join("out");
    run_ok(1, &scene, &base);
    let measured = ["contact_imbalance", "contact_bytes"];
    for np in [2, 3, 4] {
        let out = workdir(&format!("one_answer_np{np}")).join("out");
        run_ok(np, &scene, &out);
        if let Err(e) = fields_differ(&base, &out) {
            panic!("np {np} against np 1: fields.h5 {e} (same bits expected)");
        }
        let probes = csv_columns_differ(&base, &out, "probes.csv", &[]);
        assert!(
            probes.is_empty(),
            "np {np} against np 1: probes.csv columns differ (column, first row): {probes:?}"
        );
        let bad = csv_columns_differ(&base, &out, "history.csv", &measured);
        assert!(
            bad.is_empty(),
            "np {np} against np 1: history.csv columns differ (column, first row): {bad:?}"
        );
    }
}
