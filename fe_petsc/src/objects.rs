//! Owning wrappers for the PETSc objects the project uses: each destroys its object on drop.
use crate::petsc::PetscError;
use crate::petsc_call;
use petsc_sys as sys;

/// An owned `DM` (a DMPlex here).
pub struct Dm(pub(crate) sys::DM);
/// An owned `Vec`.
pub struct Vector(pub(crate) sys::Vec);
/// An owned `PetscSF` (star forest).
pub struct StarForest(pub(crate) sys::PetscSF);
/// An owned `PetscSection`.
pub struct Section(pub(crate) sys::PetscSection);
/// An owned `IS`.
pub struct IndexSet(pub(crate) sys::IS);

impl Drop for Dm {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::DMDestroy(&mut self.0) };
        }
    }
}
impl Drop for Vector {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::VecDestroy(&mut self.0) };
        }
    }
}
impl Drop for StarForest {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::PetscSFDestroy(&mut self.0) };
        }
    }
}
impl Drop for Section {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::PetscSectionDestroy(&mut self.0) };
        }
    }
}
impl Drop for IndexSet {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::ISDestroy(&mut self.0) };
        }
    }
}

impl IndexSet {
    /// Copies the indices out.
    pub fn to_vec(&self) -> Result<Vec<i32>, PetscError> {
        if self.0.is_null() {
            return Ok(Vec::new());
        }
        let mut n: sys::PetscInt = 0;
        petsc_call!(ISGetLocalSize(self.0, &mut n))?;
        let mut p: *const sys::PetscInt = std::ptr::null();
        petsc_call!(ISGetIndices(self.0, &mut p))?;
        let v = if n > 0 {
            // SAFETY: PETSc gives n valid indices until ISRestoreIndices.
            unsafe { std::slice::from_raw_parts(p, n as usize) }.to_vec()
        } else {
            Vec::new()
        };
        petsc_call!(ISRestoreIndices(self.0, &mut p))?;
        Ok(v)
    }
}

impl Dm {
    /// The chart [start, end) of points.
    pub fn chart(&self) -> Result<(i32, i32), PetscError> {
        let (mut a, mut b) = (0, 0);
        petsc_call!(DMPlexGetChart(self.0, &mut a, &mut b))?;
        Ok((a, b))
    }
    /// Points of the given depth (0 = vertices).
    pub fn depth_stratum(&self, d: i32) -> Result<(i32, i32), PetscError> {
        let (mut a, mut b) = (0, 0);
        petsc_call!(DMPlexGetDepthStratum(self.0, d, &mut a, &mut b))?;
        Ok((a, b))
    }
    /// Points of the given height (0 = cells).
    pub fn height_stratum(&self, h: i32) -> Result<(i32, i32), PetscError> {
        let (mut a, mut b) = (0, 0);
        petsc_call!(DMPlexGetHeightStratum(self.0, h, &mut a, &mut b))?;
        Ok((a, b))
    }
    /// The points in the closure of `p`, in PETSc's closure order (orientations dropped).
    pub fn closure(&self, p: i32, out: &mut Vec<i32>) -> Result<(), PetscError> {
        let mut n: sys::PetscInt = 0;
        let mut pts: *mut sys::PetscInt = std::ptr::null_mut();
        petsc_call!(DMPlexGetTransitiveClosure(
            self.0,
            p,
            sys::PETSC_TRUE,
            &mut n,
            &mut pts
        ))?;
        out.clear();
        // SAFETY: closure array holds n (point, orientation) pairs until restored.
        let s = unsafe { std::slice::from_raw_parts(pts, 2 * n as usize) };
        out.extend(s.chunks(2).map(|c| c[0]));
        petsc_call!(DMPlexRestoreTransitiveClosure(
            self.0,
            p,
            sys::PETSC_TRUE,
            &mut n,
            &mut pts
        ))?;
        Ok(())
    }
    /// The cone (points covered by `p`).
    pub fn cone(&self, p: i32) -> Result<Vec<i32>, PetscError> {
        let mut n = 0;
        petsc_call!(DMPlexGetConeSize(self.0, p, &mut n))?;
        let mut c: *const sys::PetscInt = std::ptr::null();
        petsc_call!(DMPlexGetCone(self.0, p, &mut c))?;
        Ok(if n > 0 {
            unsafe { std::slice::from_raw_parts(c, n as usize) }.to_vec()
        } else {
            Vec::new()
        })
    }
    /// The support (points covering `p`).
    pub fn support(&self, p: i32) -> Result<Vec<i32>, PetscError> {
        let mut n = 0;
        petsc_call!(DMPlexGetSupportSize(self.0, p, &mut n))?;
        let mut c: *const sys::PetscInt = std::ptr::null();
        petsc_call!(DMPlexGetSupport(self.0, p, &mut c))?;
        Ok(if n > 0 {
            unsafe { std::slice::from_raw_parts(c, n as usize) }.to_vec()
        } else {
            Vec::new()
        })
    }
    /// Value of label `name` at point `p` (-1 when unset or the label is absent).
    pub fn label_value(&self, name: &std::ffi::CStr, p: i32) -> Result<i32, PetscError> {
        let mut has: sys::PetscBool = 0;
        petsc_call!(DMHasLabel(self.0, name.as_ptr(), &mut has))?;
        if has == 0 {
            return Ok(-1);
        }
        let mut v = -1;
        petsc_call!(DMGetLabelValue(self.0, name.as_ptr(), p, &mut v))?;
        Ok(v)
    }
    /// The distinct values of label `name` on this process.
    pub fn label_values(&self, name: &std::ffi::CStr) -> Result<Vec<i32>, PetscError> {
        let mut has: sys::PetscBool = 0;
        petsc_call!(DMHasLabel(self.0, name.as_ptr(), &mut has))?;
        if has == 0 {
            return Ok(Vec::new());
        }
        let mut is = IndexSet(std::ptr::null_mut());
        petsc_call!(DMGetLabelIdIS(self.0, name.as_ptr(), &mut is.0))?;
        is.to_vec()
    }
    /// The points with value `v` of label `name`.
    pub fn label_stratum(&self, name: &std::ffi::CStr, v: i32) -> Result<Vec<i32>, PetscError> {
        let mut is = IndexSet(std::ptr::null_mut());
        petsc_call!(DMGetStratumIS(self.0, name.as_ptr(), v, &mut is.0))?;
        is.to_vec()
    }
}
