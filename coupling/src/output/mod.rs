//! The run's output (SCENE.md "Output"): `fields.h5` + `fields.xmf` written by all ranks in
//! parallel, `history.csv` and `probes.csv` by rank 0, `report.json`.
mod fields;
mod history;
mod report;

pub use fields::{
    redistribute_by_id, ElementFrame, FieldWriter, GlobalCounts, NodeFrame, ParticleFrame,
};
pub use history::History;
pub use report::{Report, StageStats};

/// Output errors.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// HDF5 failed.
    #[error("HDF5: {0}")]
    Hdf5(#[from] hdf5::Error),
    /// File system.
    #[error("{0}")]
    Io(#[from] std::io::Error),
}
