//! `fields.h5`/`fields.xmf`, `history.csv` and `report.json` written under mpirun at 1, 2 and 3
//! ranks (items scattered over the ranks out of id order) and read back exactly by rank 0.
use std::path::PathBuf;
use std::process::Command;

/// Seconds before a hung run is killed.
const RUN_TIMEOUT_S: &str = "120";

#[test]
fn output_round_trip_is_exact_at_1_2_3_ranks() {
    for np in 1..=3 {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("output_mpi_np{np}"));
        let _ = std::fs::remove_dir_all(&dir);
        let o = Command::new("timeout")
            .args([RUN_TIMEOUT_S, "mpirun", "-np", &np.to_string()])
            .arg(env!("CARGO_BIN_EXE_tdyn_selftest"))
            .arg("output")
            .arg(&dir)
            .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
            .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
            .env("OMPI_MCA_orte_tmpdir_base", tdyn_tests::session_base())
            .output()
            .expect("mpirun could not be started");
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success() && out.contains(&format!("passed at np {np}")),
            "np {np}: exact round trip of every dataset row, attribute and CSV value expected\n{out}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}
