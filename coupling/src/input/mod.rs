//! What a run reads: the scene file, gmsh meshes, particle files (LIGGGHTS data files).
pub mod gmsh;
pub mod liggghts;
pub mod particles;
pub mod scene;
