//! The two kernels of the paper's §3, used by every stage: the unstructured-communication plan
//! (Fig. 5), recursive coordinate bisection (Figs. 6, 7), and the collectives through which every
//! rank agrees on success or failure.
pub mod collective;
pub mod comm;
pub mod rcb;
