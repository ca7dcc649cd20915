//! `report.json`: what ran, how long each stage took, its balance and bytes moved.
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use serde::Serialize;
use std::path::Path;

/// One stage's figures, reduced over the ranks.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct StageStats {
    /// Wall time, max over ranks, s.
    pub wall_s: f64,
    /// Max/mean over ranks of the stage's work (1 when there is none).
    pub imbalance: f64,
    /// Bytes sent, summed over ranks.
    pub bytes_sent: f64,
}

impl StageStats {
    /// Reduces the local figures (collective).
    pub fn reduce(comm: &SimpleCommunicator, wall_s: f64, work: f64, bytes: f64) -> StageStats {
        let mut mx = [0.0; 2];
        comm.all_reduce_into(&[wall_s, work][..], &mut mx[..], SystemOperation::max());
        let mut sm = [0.0; 2];
        comm.all_reduce_into(&[work, bytes][..], &mut sm[..], SystemOperation::sum());
        let mean = sm[0] / comm.size() as f64;
        StageStats {
            wall_s: mx[0],
            imbalance: if mean > 0.0 { mx[1] / mean } else { 1.0 },
            bytes_sent: sm[1],
        }
    }
}

/// The run's report (docs/scene.md).
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// MPI ranks.
    pub ranks: usize,
    /// Elements in the mesh.
    pub elements: u64,
    /// Nodes in the mesh.
    pub nodes: u64,
    /// SPH particles.
    pub particles: u64,
    /// Time steps.
    pub steps: u64,
    /// Whole run, s.
    pub wall_s: f64,
    /// The stages that ran.
    pub stages_run: Vec<String>,
    /// FE stage.
    pub fe: Option<StageStats>,
    /// SPH stage.
    pub sph: Option<StageStats>,
    /// Contact stage.
    pub contact: Option<StageStats>,
    /// Transfers between decompositions.
    pub transfer: Option<StageStats>,
    /// RCB.
    pub rcb: Option<StageStats>,
    /// Output.
    pub output: Option<StageStats>,
    /// Time-step loop wall time x ranks / (elements x steps), ns.
    pub ns_per_element_cycle: Option<f64>,
    /// Likewise per particle-step, us.
    pub us_per_particle_step: Option<f64>,
    /// Largest energy error seen.
    pub energy_error_max: f64,
    /// Other figures (title, mode, step sizes, timing split, memory).
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

impl Report {
    /// A report with the counts filled in and no stage figures.
    pub fn new(
        ranks: usize,
        elements: u64,
        nodes: u64,
        particles: u64,
        steps: u64,
        wall_s: f64,
    ) -> Self {
        Report {
            ranks,
            elements,
            nodes,
            particles,
            steps,
            wall_s,
            stages_run: Vec::new(),
            fe: None,
            sph: None,
            contact: None,
            transfer: None,
            rcb: None,
            output: None,
            ns_per_element_cycle: None,
            us_per_particle_step: None,
            energy_error_max: 0.0,
            extra: serde_json::Map::new(),
        }
    }

    /// Writes pretty JSON.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(std::io::Error::other)?;
        std::fs::write(path, text + "\n")
    }
}
