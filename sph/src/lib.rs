//! Serial SPH physics inside one box (no MPI). Built under the SPH issue.
#![warn(missing_docs)]
