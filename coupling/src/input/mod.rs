//! What a run reads: the scene file, gmsh meshes, particle files (LIGGGHTS data files).
pub mod curve;
pub mod gmsh;
pub mod liggghts;
pub mod msh_check;
pub mod particles;
pub mod scene;
pub mod split;
