//! Moving records between the decompositions: the FE owners' contact nodes and faces to the
//! contact stage, and its forces back.
pub mod fe_contact;
