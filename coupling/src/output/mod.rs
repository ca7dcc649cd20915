//! The run's output (docs/scene.md "Output"): `fields.h5` + `fields.xmf` written by all ranks in
//! parallel, `history.csv`, `probes.csv` and `reactions.csv` by rank 0, `report.json`.
mod by_id;
mod dump;
mod fields;
mod history;
mod reactions;
mod report;
pub mod state;

pub use dump::{write_particle_dump, DUMP_COLUMNS};
pub use fields::{
    Connectivity, ElementFrame, FieldWriter, GlobalCounts, NodeFrame, ParticleFrame, Values,
};
pub use history::History;
pub use reactions::{exact_forces, force_columns, ForceHistory};
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
    /// The data given do not fit the layout (ids not 0..N once each, a part given on some ranks
    /// only), or rank 0 could not write the XDMF index. Returned on every rank alike, so that no
    /// rank is left waiting in a collective call.
    #[error("{0}")]
    Layout(String),
}
