//! The contact stage (Fig. 3, steps 4-5; Fig. 10): contact nodes and particles on their own RCB
//! decomposition, the search and the push-back.
pub mod baseline;
pub mod stage;
