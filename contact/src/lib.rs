//! Serial contact physics inside one box (no MPI). Built under the contact issue.
#![warn(missing_docs)]
