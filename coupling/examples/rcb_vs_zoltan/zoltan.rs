//! Zoltan's C interface, the subset `rcb_vs_zoltan` uses: the library's entry points, the query
//! callbacks over the records, and safe owners of a `Zoltan_Struct` and of its export lists.
use super::Rec;
use mpi::raw::AsRaw;
use mpi::topology::SimpleCommunicator;
use std::ffi::{c_char, c_int, c_void, CString};

/// `ZOLTAN_ID_TYPE` of this Zoltan build: `unsigned int`.
pub(crate) type ZoltanId = u32;
pub(crate) const ZOLTAN_OK: c_int = 0;
const ZOLTAN_FATAL: c_int = -1;

/// Opaque `struct Zoltan_Struct`.
#[repr(C)]
struct ZoltanStruct {
    _private: [u8; 0],
}

type NumFn = unsafe extern "C" fn(data: *mut c_void, ierr: *mut c_int) -> c_int;
type ObjListFn = unsafe extern "C" fn(
    data: *mut c_void,
    num_gid_entries: c_int,
    num_lid_entries: c_int,
    global_ids: *mut ZoltanId,
    local_ids: *mut ZoltanId,
    wdim: c_int,
    objwgts: *mut f32,
    ierr: *mut c_int,
);
type GeomMultiFn = unsafe extern "C" fn(
    data: *mut c_void,
    num_gid_entries: c_int,
    num_lid_entries: c_int,
    num_obj: c_int,
    global_ids: *mut ZoltanId,
    local_ids: *mut ZoltanId,
    num_dim: c_int,
    geom_vec: *mut f64,
    ierr: *mut c_int,
);

#[link(name = "trilinos_zoltan")]
extern "C" {
    pub(crate) fn Zoltan_Initialize(argc: c_int, argv: *mut *mut c_char, ver: *mut f32) -> c_int;
    fn Zoltan_Create(comm: mpi::ffi::MPI_Comm) -> *mut ZoltanStruct;
    fn Zoltan_Destroy(zz: *mut *mut ZoltanStruct);
    fn Zoltan_Set_Param(zz: *mut ZoltanStruct, name: *const c_char, val: *const c_char) -> c_int;
    fn Zoltan_Set_Num_Obj_Fn(zz: *mut ZoltanStruct, f: NumFn, data: *mut c_void) -> c_int;
    fn Zoltan_Set_Obj_List_Fn(zz: *mut ZoltanStruct, f: ObjListFn, data: *mut c_void) -> c_int;
    fn Zoltan_Set_Num_Geom_Fn(zz: *mut ZoltanStruct, f: NumFn, data: *mut c_void) -> c_int;
    fn Zoltan_Set_Geom_Multi_Fn(zz: *mut ZoltanStruct, f: GeomMultiFn, data: *mut c_void) -> c_int;
    #[allow(clippy::too_many_arguments)]
    fn Zoltan_LB_Partition(
        zz: *mut ZoltanStruct,
        changes: *mut c_int,
        num_gid_entries: *mut c_int,
        num_lid_entries: *mut c_int,
        num_import: *mut c_int,
        import_global_ids: *mut *mut ZoltanId,
        import_local_ids: *mut *mut ZoltanId,
        import_procs: *mut *mut c_int,
        import_to_part: *mut *mut c_int,
        num_export: *mut c_int,
        export_global_ids: *mut *mut ZoltanId,
        export_local_ids: *mut *mut ZoltanId,
        export_procs: *mut *mut c_int,
        export_to_part: *mut *mut c_int,
    ) -> c_int;
    fn Zoltan_LB_Free_Part(
        global_ids: *mut *mut ZoltanId,
        local_ids: *mut *mut ZoltanId,
        procs: *mut *mut c_int,
        to_part: *mut *mut c_int,
    ) -> c_int;
    #[allow(clippy::too_many_arguments)]
    fn Zoltan_RCB_Box(
        zz: *mut ZoltanStruct,
        part: c_int,
        ndim: *mut c_int,
        xmin: *mut f64,
        ymin: *mut f64,
        zmin: *mut f64,
        xmax: *mut f64,
        ymax: *mut f64,
        zmax: *mut f64,
    ) -> c_int;
    fn Zoltan_LB_Point_Assign(zz: *mut ZoltanStruct, coords: *mut f64, proc_: *mut c_int) -> c_int;
}

/// What the query callbacks see: this rank's records (valid for one partition call).
struct Query {
    items: *const Rec,
    n: usize,
}

impl Query {
    /// # Safety
    /// `data` is the `Query` handed to Zoltan by [`Zoltan::partition`], alive during the call.
    unsafe fn from<'a>(data: *mut c_void) -> &'a [Rec] {
        let q = &*(data as *const Query);
        if q.n == 0 {
            &[]
        } else {
            std::slice::from_raw_parts(q.items, q.n)
        }
    }
}

unsafe extern "C" fn q_num_obj(data: *mut c_void, ierr: *mut c_int) -> c_int {
    *ierr = ZOLTAN_OK;
    Query::from(data).len() as c_int
}

unsafe extern "C" fn q_num_geom(_data: *mut c_void, ierr: *mut c_int) -> c_int {
    *ierr = ZOLTAN_OK;
    3
}

/// Global id = the point's id, local id = its index in this rank's records.
unsafe extern "C" fn q_obj_list(
    data: *mut c_void,
    num_gid_entries: c_int,
    num_lid_entries: c_int,
    global_ids: *mut ZoltanId,
    local_ids: *mut ZoltanId,
    _wdim: c_int,
    _objwgts: *mut f32,
    ierr: *mut c_int,
) {
    if num_gid_entries != 1 || num_lid_entries != 1 {
        *ierr = ZOLTAN_FATAL;
        return;
    }
    for (i, r) in Query::from(data).iter().enumerate() {
        *global_ids.add(i) = r.id as ZoltanId;
        *local_ids.add(i) = i as ZoltanId;
    }
    *ierr = ZOLTAN_OK;
}

unsafe extern "C" fn q_geom_multi(
    data: *mut c_void,
    num_gid_entries: c_int,
    num_lid_entries: c_int,
    num_obj: c_int,
    _global_ids: *mut ZoltanId,
    local_ids: *mut ZoltanId,
    num_dim: c_int,
    geom_vec: *mut f64,
    ierr: *mut c_int,
) {
    let items = Query::from(data);
    if num_gid_entries != 1 || num_lid_entries != 1 || num_dim != 3 {
        *ierr = ZOLTAN_FATAL;
        return;
    }
    for k in 0..num_obj as usize {
        let i = *local_ids.add(k) as usize;
        let Some(r) = items.get(i) else {
            *ierr = ZOLTAN_FATAL;
            return;
        };
        for d in 0..3 {
            *geom_vec.add(3 * k + d) = r.x[d];
        }
    }
    *ierr = ZOLTAN_OK;
}

/// A `Zoltan_Struct` set up for RCB over `comm`; destroyed on drop.
pub(crate) struct Zoltan {
    zz: *mut ZoltanStruct,
}

/// The export lists of one `Zoltan_LB_Partition` (freed on drop).
pub(crate) struct Exports {
    pub(crate) n: usize,
    gids: *mut ZoltanId,
    lids: *mut ZoltanId,
    procs: *mut c_int,
    parts: *mut c_int,
}

impl Exports {
    fn slice<T>(&self, p: *mut T) -> &[T] {
        if self.n == 0 || p.is_null() {
            &[]
        } else {
            // SAFETY: Zoltan allocated n entries for each export array.
            unsafe { std::slice::from_raw_parts(p, self.n) }
        }
    }
    pub(crate) fn gids(&self) -> &[ZoltanId] {
        self.slice(self.gids)
    }
    pub(crate) fn lids(&self) -> &[ZoltanId] {
        self.slice(self.lids)
    }
    pub(crate) fn procs(&self) -> &[c_int] {
        self.slice(self.procs)
    }
    pub(crate) fn parts(&self) -> &[c_int] {
        self.slice(self.parts)
    }
}

impl Drop for Exports {
    fn drop(&mut self) {
        // SAFETY: arrays from Zoltan_LB_Partition, freed once.
        unsafe {
            Zoltan_LB_Free_Part(
                &mut self.gids,
                &mut self.lids,
                &mut self.procs,
                &mut self.parts,
            );
        }
    }
}

impl Zoltan {
    pub(crate) fn new(comm: &SimpleCommunicator, params: &[(&str, String)]) -> Zoltan {
        // SAFETY: MPI is initialised; Zoltan duplicates the communicator.
        let zz = unsafe { Zoltan_Create(comm.as_raw()) };
        assert!(!zz.is_null(), "Zoltan_Create failed");
        let z = Zoltan { zz };
        for (k, v) in params {
            let (ck, cv) = (CString::new(*k).unwrap(), CString::new(v.as_str()).unwrap());
            // SAFETY: valid structure and NUL-terminated strings.
            let rc = unsafe { Zoltan_Set_Param(z.zz, ck.as_ptr(), cv.as_ptr()) };
            assert_eq!(rc, ZOLTAN_OK, "Zoltan_Set_Param({k}, {v}) failed");
        }
        z
    }

    /// One `Zoltan_LB_Partition` over `items` (collective).
    pub(crate) fn partition(&mut self, items: &[Rec]) -> Exports {
        let mut q = Query {
            items: items.as_ptr(),
            n: items.len(),
        };
        let data = &mut q as *mut Query as *mut c_void;
        let (mut changes, mut ngid, mut nlid) = (0, 0, 0);
        let mut n_imp: c_int = 0;
        let mut imp_g: *mut ZoltanId = std::ptr::null_mut();
        let mut imp_l: *mut ZoltanId = std::ptr::null_mut();
        let mut imp_p: *mut c_int = std::ptr::null_mut();
        let mut imp_t: *mut c_int = std::ptr::null_mut();
        let mut n_exp: c_int = 0;
        let mut ex = Exports {
            n: 0,
            gids: std::ptr::null_mut(),
            lids: std::ptr::null_mut(),
            procs: std::ptr::null_mut(),
            parts: std::ptr::null_mut(),
        };
        // SAFETY: the callbacks read `q`, which outlives the call; Zoltan fills the out-params.
        let rc = unsafe {
            Zoltan_Set_Num_Obj_Fn(self.zz, q_num_obj, data);
            Zoltan_Set_Obj_List_Fn(self.zz, q_obj_list, data);
            Zoltan_Set_Num_Geom_Fn(self.zz, q_num_geom, data);
            Zoltan_Set_Geom_Multi_Fn(self.zz, q_geom_multi, data);
            let rc = Zoltan_LB_Partition(
                self.zz,
                &mut changes,
                &mut ngid,
                &mut nlid,
                &mut n_imp,
                &mut imp_g,
                &mut imp_l,
                &mut imp_p,
                &mut imp_t,
                &mut n_exp,
                &mut ex.gids,
                &mut ex.lids,
                &mut ex.procs,
                &mut ex.parts,
            );
            Zoltan_LB_Free_Part(&mut imp_g, &mut imp_l, &mut imp_p, &mut imp_t);
            rc
        };
        assert!(
            rc == ZOLTAN_OK || rc == 1, // ZOLTAN_WARN
            "Zoltan_LB_Partition returned {rc}"
        );
        assert!(ngid == 1 && nlid == 1, "id sizes {ngid}, {nlid}");
        ex.n = n_exp.max(0) as usize;
        ex
    }

    /// The rank whose region holds `x` (needs KEEP_CUTS=1).
    pub(crate) fn point_owner(&self, x: &[f64; 3]) -> i32 {
        let mut c = *x;
        let mut p: c_int = -1;
        // SAFETY: valid structure, 3 coordinates.
        let rc = unsafe { Zoltan_LB_Point_Assign(self.zz, c.as_mut_ptr(), &mut p) };
        assert_eq!(rc, ZOLTAN_OK, "Zoltan_LB_Point_Assign failed");
        p
    }
}

impl Zoltan {
    /// The box of `part` (needs KEEP_CUTS=1): lower and upper bounds per axis.
    pub(crate) fn rcb_box(&self, part: i32) -> ([f64; 3], [f64; 3]) {
        let (mut lo, mut hi) = ([0.0f64; 3], [0.0f64; 3]);
        let mut ndim: c_int = 0;
        // SAFETY: valid structure, six output doubles.
        let rc = unsafe {
            let [x0, y0, z0] = &mut lo;
            let [x1, y1, z1] = &mut hi;
            Zoltan_RCB_Box(self.zz, part, &mut ndim, x0, y0, z0, x1, y1, z1)
        };
        assert_eq!(rc, ZOLTAN_OK, "Zoltan_RCB_Box failed");
        (lo, hi)
    }
}

impl Drop for Zoltan {
    fn drop(&mut self) {
        // SAFETY: created by Zoltan_Create, destroyed once.
        unsafe { Zoltan_Destroy(&mut self.zz) };
    }
}
