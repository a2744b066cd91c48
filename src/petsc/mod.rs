//! Layer `petsc`: the one home of PETSc: the unsafe FFI (`ffi`) and safe RAII wrappers around
//! it, and the `-log_view` stages of a run ([`log`]).
//!
//! Every `PetscErrorCode` becomes a [`PetscError`] carrying PETSc's own message; PETSc's
//! traceback printer is replaced by a returning error handler, so an error reaches the user
//! as one line. Nothing outside this module calls FFI.
//!
//! May use: nothing of this crate (the bottom layer).

mod ffi;
pub mod log;
pub mod readers;
pub mod signals;

use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int};
use std::ptr;

/// An MPI communicator handed to PETSc. Made only from valid communicators
/// ([`Petsc::comm_world`], [`comm_from_rsmpi`]), so passing it on is safe.
#[derive(Clone, Copy, Debug)]
pub struct Comm(ffi::MPI_Comm);

/// PETSc's `PetscInt` (32-bit in Debian's build).
pub type Int = ffi::PetscInt;

const PETSC_DETERMINE: Int = -1;

/// The largest block of right-hand sides of [`Ksp::mumps_inverse_block`] (MUMPS's ICNTL(27)).
const INVERSE_BLOCK: Int = 1024;

/// A PETSc call that failed.
#[derive(Debug, thiserror::Error)]
#[error("PETSc error {code} in {call}: {message}")]
pub struct PetscError {
    pub code: i32,
    pub call: &'static str,
    pub message: String,
}

pub type Result<T> = std::result::Result<T, PetscError>;

impl PetscError {
    /// The same error, reported as a bad value of option `name`.
    fn for_option(mut self, name: &str) -> PetscError {
        self.message = format!("{name}: {}", self.message);
        self
    }
}

fn check(code: ffi::PetscErrorCode, call: &'static str) -> Result<()> {
    if code == 0 {
        return Ok(());
    }
    let mut text: *const c_char = ptr::null();
    let mut specific: *mut c_char = ptr::null_mut();
    // SAFETY: PetscErrorMessage only writes the two pointers to static strings.
    unsafe { ffi::PetscErrorMessage(code, &mut text, &mut specific) };
    let pick = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: PETSc returns NUL-terminated static buffers.
            unsafe { CStr::from_ptr(p) }
                .to_string_lossy()
                .trim()
                .to_string()
        }
    };
    let mut message = pick(specific);
    if message.is_empty() {
        message = pick(text);
    }
    Err(PetscError {
        code,
        call,
        message: message.replace('\n', " "),
    })
}

macro_rules! call {
    ($f:ident ( $($arg:expr),* $(,)? )) => {
        check(unsafe { ffi::$f($($arg),*) }, stringify!($f))
    };
}

fn cstr(s: &str) -> CString {
    CString::new(s).expect("option strings never contain NUL")
}

/// An initialised PETSc. Create it once per process after MPI; dropping it finalises PETSc.
pub struct Petsc {
    _argv: Vec<CString>,
}

/// A failure to restore SIGPIPE's default disposition.
fn pipe_error(e: std::io::Error) -> PetscError {
    PetscError {
        code: 0,
        call: "signal(SIGPIPE, SIG_DFL)",
        message: e.to_string(),
    }
}

impl Petsc {
    /// `PetscInitialize` with the process arguments; `help` is printed by `-help`.
    pub fn initialize(args: &[String], help: &str) -> Result<Petsc> {
        let argv_owned: Vec<CString> = args.iter().map(|a| cstr(a)).collect();
        // PETSc keeps argv: leak the pointer array for the life of the process.
        let mut ptrs: Vec<*mut c_char> = argv_owned
            .iter()
            .map(|a| a.as_ptr() as *mut c_char)
            .collect();
        ptrs.push(ptr::null_mut());
        let ptrs = Box::leak(ptrs.into_boxed_slice());
        let mut argc: c_int = args.len() as c_int;
        let mut argv: *mut *mut c_char = ptrs.as_mut_ptr();
        let help = Box::leak(cstr(help).into_boxed_c_str());
        // `-help` prints inside PetscInitialize, after PETSc has trapped SIGPIPE: a listing
        // piped into `head` would end in its handler. The listing does nothing else, so it
        // runs without PETSc's signal handlers (the options database takes values before
        // PetscInitialize).
        if args.iter().any(|a| a == "-help") {
            let flag = cstr("-no_signal_handler");
            call!(PetscOptionsSetValue(
                ptr::null_mut(),
                flag.as_ptr(),
                ptr::null()
            ))?;
            signals::default_broken_pipe().map_err(pipe_error)?;
        }
        call!(PetscInitialize(
            &mut argc,
            &mut argv,
            ptr::null(),
            help.as_ptr()
        ))?;
        // Errors come back as codes; we print them as one line ourselves.
        call!(PetscPushErrorHandler(
            Some(ffi::PetscReturnErrorHandler),
            ptr::null_mut()
        ))?;
        let petsc = Petsc { _argv: argv_owned };
        signals::default_broken_pipe().map_err(pipe_error)?;
        Ok(petsc)
    }

    /// `MPI_COMM_SELF` (a macro in C, so taken from rsmpi).
    pub fn comm_self() -> Comm {
        use mpi::traits::AsRaw;
        comm_from_rsmpi(mpi::topology::SimpleCommunicator::self_comm().as_raw())
    }

    /// `PETSC_COMM_WORLD`.
    pub fn comm_world() -> Comm {
        // SAFETY: a global set by PetscInitialize.
        Comm(unsafe { ffi::PETSC_COMM_WORLD })
    }

    /// The floating-point operations PETSc logged on this process so far (what `-log_view`
    /// sums over the ranks).
    pub fn logged_flops() -> f64 {
        let mut flops = 0.0;
        // SAFETY: PetscGetFlops only reads PETSc's counter.
        if unsafe { ffi::PetscGetFlops(&mut flops) } != 0 {
            return 0.0;
        }
        flops
    }

    /// Ask PETSc to track the peak resident memory (`-memory_view` style).
    pub fn track_memory() -> Result<()> {
        call!(PetscMemorySetGetMaximumUsage())
    }

    /// Peak resident set size of this process in bytes: the kernel's high-water mark
    /// (getrusage's ru_maxrss). PETSc's `PetscMemoryGetMaximumUsage` only samples the resident
    /// size when PETSc objects are destroyed, so it missed transient peaks between them (the
    /// estimate's: at n = 512 it reported 977 MiB where the high-water mark was 1304 MiB).
    pub fn peak_memory() -> f64 {
        // SAFETY: getrusage fills the zeroed struct it is given.
        let mut r: libc::rusage = unsafe { std::mem::zeroed() };
        if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut r) } != 0 {
            return 0.0;
        }
        r.ru_maxrss as f64 * 1024.0 // kilobytes on Linux
    }

    /// Give the heap's free pages back to the system (glibc's `malloc_trim`) when at least
    /// `min_bytes` are free in it. Arrays under glibc's mmap threshold (which grows to 32 MiB
    /// as large blocks are freed) live in the heap and stay resident after they are freed, so
    /// without this a phase's freed arrays still count when the next phase allocates others.
    /// Below the threshold the pages are kept: faulting them in again costs more than they
    /// weigh.
    pub fn release_free_memory(min_bytes: usize) {
        // SAFETY: mallinfo2 only reads the allocator's statistics, and malloc_trim only
        // returns unused pages of its own heaps.
        unsafe {
            if libc::mallinfo2().fordblks >= min_bytes {
                libc::malloc_trim(0);
            }
        }
    }
}

impl Drop for Petsc {
    fn drop(&mut self) {
        // SAFETY: every PETSc object is dropped before `Petsc` by construction of `main`.
        unsafe { ffi::PetscFinalize() };
    }
}

/// Convert an rsmpi raw communicator into PETSc's `MPI_Comm` (both are OpenMPI's
/// `ompi_communicator_t *`; the two bindings only name the type differently).
pub fn comm_from_rsmpi(raw: mpi::ffi::MPI_Comm) -> Comm {
    Comm(raw.0 as ffi::MPI_Comm)
}

// ---------------------------------------------------------------------------------------------
// Options

/// Whether an option is present in the options database (e.g. `-help`).
pub fn option_present(name: &str) -> bool {
    let mut set: ffi::PetscBool = ffi::PETSC_FALSE;
    let n = cstr(name);
    call!(PetscOptionsHasName(
        ptr::null_mut(),
        ptr::null(),
        n.as_ptr(),
        &mut set
    ))
    .is_ok()
        && set == ffi::PETSC_TRUE
}

/// The value of option `name` in the options database, if it is set.
pub fn option_string(name: &str) -> Result<Option<String>> {
    let mut buf = vec![0 as c_char; 256];
    let mut set = ffi::PETSC_FALSE;
    let n = cstr(name);
    call!(PetscOptionsGetString(
        ptr::null_mut(),
        ptr::null(),
        n.as_ptr(),
        buf.as_mut_ptr(),
        buf.len(),
        &mut set
    ))?;
    if !to_bool(set) {
        return Ok(None);
    }
    // SAFETY: PETSc wrote a NUL-terminated string into `buf`.
    let v = unsafe { CStr::from_ptr(buf.as_ptr()) };
    Ok(Some(v.to_string_lossy().into_owned()))
}

/// Every option in the database as PETSc lists it (`PetscOptionsGetAll`: `-name value`
/// pairs separated by spaces). The string PETSc allocates is left to it (a few bytes, once or
/// twice per run: `PetscFree` is a macro).
pub fn options_text() -> Result<String> {
    let mut all: *mut std::os::raw::c_char = ptr::null_mut();
    call!(PetscOptionsGetAll(ptr::null_mut(), &mut all))?;
    if all.is_null() {
        return Ok(String::new());
    }
    // SAFETY: PETSc returns a NUL-terminated string it owns.
    let text = unsafe { std::ffi::CStr::from_ptr(all) };
    Ok(text.to_string_lossy().trim().to_string())
}

/// The names of every option in the database, e.g. to find the `-nndd_bc_…` options that
/// name no boundary.
pub fn option_names() -> Result<Vec<String>> {
    Ok(names_in(&options_text()?))
}

/// The option names in a listing of options as [`options_text`] gives it.
pub fn names_in(text: &str) -> Vec<String> {
    text.split_whitespace()
        .filter(|t| t.starts_with('-') && t[1..].starts_with(|c: char| c.is_ascii_alphabetic()))
        .map(str::to_string)
        .collect()
}

/// The options given that nothing on this process has read (PETSc's `-options_left`), as
/// `-name`.
pub fn unused_options() -> Result<Vec<String>> {
    let mut n: Int = 0;
    let mut names: *mut *mut c_char = ptr::null_mut();
    let mut values: *mut *mut c_char = ptr::null_mut();
    call!(PetscOptionsLeftGet(
        ptr::null_mut(),
        &mut n,
        &mut names,
        &mut values
    ))?;
    let mut out = Vec::with_capacity(n.max(0) as usize);
    for i in 0..n.max(0) as usize {
        // SAFETY: PETSc returns n NUL-terminated names, valid until the restore below.
        let name = unsafe { CStr::from_ptr(*names.add(i)) }.to_string_lossy();
        out.push(format!("-{}", name.trim_start_matches('-')));
    }
    call!(PetscOptionsLeftRestore(
        ptr::null_mut(),
        &mut n,
        &mut names,
        &mut values
    ))?;
    Ok(out)
}

pub fn option_default(name: &str, value: &str) -> Result<()> {
    if option_present(name) {
        return Ok(());
    }
    let (n, v) = (cstr(name), cstr(value));
    call!(PetscOptionsSetValue(
        ptr::null_mut(),
        n.as_ptr(),
        v.as_ptr()
    ))
}

/// A block of registered options (`PetscOptionsBegin` … `PetscOptionsEnd`): each query
/// registers the option with its help text, so `-help` lists it with its default.
pub struct OptionsBlock {
    items: Box<ffi::PetscOptionItems>,
    ended: bool,
    /// Every option name queried, in order (the options the program knows).
    queried: Vec<String>,
}

fn to_bool(b: ffi::PetscBool) -> bool {
    b == ffi::PETSC_TRUE
}

impl OptionsBlock {
    pub fn begin(comm: Comm, title: &str, mansec: &str) -> Result<OptionsBlock> {
        // SAFETY: PetscOptionItems is a plain C struct, zero-initialised as the C macro does.
        let mut items: Box<ffi::PetscOptionItems> = Box::new(unsafe { std::mem::zeroed() });
        items.count = 1; // one pass: no SAWs publishing
        let (t, m) = (cstr(title), cstr(mansec));
        call!(PetscOptionsBegin_Private(
            &mut *items,
            comm.0,
            ptr::null(),
            t.as_ptr(),
            m.as_ptr()
        ))?;
        Ok(OptionsBlock {
            items,
            ended: false,
            queried: Vec::new(),
        })
    }

    pub fn real(&mut self, name: &str, help: &str, default: f64) -> Result<(f64, bool)> {
        self.queried.push(name.to_string());
        self.real_(name, help, default)
            .map_err(|e| e.for_option(name))
    }

    fn real_(&mut self, name: &str, help: &str, default: f64) -> Result<(f64, bool)> {
        let (n, h, m) = (cstr(name), cstr(help), cstr("None"));
        let mut value = default;
        let mut set = ffi::PETSC_FALSE;
        call!(PetscOptionsReal_Private(
            &mut *self.items,
            n.as_ptr(),
            h.as_ptr(),
            m.as_ptr(),
            default,
            &mut value,
            &mut set
        ))?;
        Ok((value, to_bool(set)))
    }

    pub fn int(&mut self, name: &str, help: &str, default: i64) -> Result<(i64, bool)> {
        self.queried.push(name.to_string());
        self.int_(name, help, default)
            .map_err(|e| e.for_option(name))
    }

    fn int_(&mut self, name: &str, help: &str, default: i64) -> Result<(i64, bool)> {
        let (n, h, m) = (cstr(name), cstr(help), cstr("None"));
        let mut value: Int = default as Int;
        let mut set = ffi::PETSC_FALSE;
        call!(PetscOptionsInt_Private(
            &mut *self.items,
            n.as_ptr(),
            h.as_ptr(),
            m.as_ptr(),
            default as Int,
            &mut value,
            &mut set,
            Int::MIN + 1,
            Int::MAX
        ))?;
        Ok((value as i64, to_bool(set)))
    }

    pub fn string(&mut self, name: &str, help: &str, default: &str) -> Result<(String, bool)> {
        self.queried.push(name.to_string());
        let (n, h, m, d) = (cstr(name), cstr(help), cstr("None"), cstr(default));
        let mut buf = vec![0 as c_char; 4096];
        let mut set = ffi::PETSC_FALSE;
        call!(PetscOptionsString_Private(
            &mut *self.items,
            n.as_ptr(),
            h.as_ptr(),
            m.as_ptr(),
            d.as_ptr(),
            buf.as_mut_ptr(),
            buf.len(),
            &mut set
        ))?;
        let value = if to_bool(set) {
            // SAFETY: PETSc NUL-terminates within the buffer.
            unsafe { CStr::from_ptr(buf.as_ptr()) }
                .to_string_lossy()
                .into_owned()
        } else {
            default.to_string()
        };
        Ok((value, to_bool(set)))
    }

    pub fn flag(&mut self, name: &str, help: &str, default: bool) -> Result<bool> {
        self.queried.push(name.to_string());
        self.flag_(name, help, default)
            .map_err(|e| e.for_option(name))
    }

    fn flag_(&mut self, name: &str, help: &str, default: bool) -> Result<bool> {
        let (n, h, m) = (cstr(name), cstr(help), cstr("None"));
        let d = if default {
            ffi::PETSC_TRUE
        } else {
            ffi::PETSC_FALSE
        };
        let mut value = d;
        let mut set = ffi::PETSC_FALSE;
        call!(PetscOptionsBool_Private(
            &mut *self.items,
            n.as_ptr(),
            h.as_ptr(),
            m.as_ptr(),
            d,
            &mut value,
            &mut set
        ))?;
        Ok(to_bool(value))
    }

    /// The option names queried so far.
    pub fn queried(&self) -> &[String] {
        &self.queried
    }

    pub fn end(mut self) -> Result<()> {
        self.ended = true;
        call!(PetscOptionsEnd_Private(&mut *self.items))
    }
}

impl Drop for OptionsBlock {
    fn drop(&mut self) {
        if !self.ended {
            unsafe { ffi::PetscOptionsEnd_Private(&mut *self.items) };
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Logging

/// A `-log_view` stage.
#[derive(Clone, Copy, Debug)]
pub struct LogStage(ffi::PetscLogStage);

impl LogStage {
    pub fn register(name: &str) -> Result<LogStage> {
        let n = cstr(name);
        let mut s: ffi::PetscLogStage = 0;
        call!(PetscLogStageRegister(n.as_ptr(), &mut s))?;
        Ok(LogStage(s))
    }

    /// Push the stage; it is popped when the guard drops.
    pub fn enter(self) -> StageGuard {
        let ok = call!(PetscLogStagePush(self.0)).is_ok();
        StageGuard(ok)
    }
}

pub struct StageGuard(bool);

impl Drop for StageGuard {
    fn drop(&mut self) {
        if self.0 {
            unsafe { ffi::PetscLogStagePop() };
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Index sets

struct Is(ffi::IS);

impl Is {
    fn new(comm: Comm, idx: &[Int]) -> Result<Is> {
        let mut is: ffi::IS = ptr::null_mut();
        call!(ISCreateGeneral(
            comm.0,
            idx.len() as Int,
            idx.as_ptr(),
            ffi::PETSC_COPY_VALUES,
            &mut is
        ))?;
        Ok(Is(is))
    }
}

impl Drop for Is {
    fn drop(&mut self) {
        unsafe { ffi::ISDestroy(&mut self.0) };
    }
}

// ---------------------------------------------------------------------------------------------
// Vectors

/// A PETSc vector (sequential or distributed over `comm`).
pub struct Vector(ffi::Vec);

impl Vector {
    /// A vector with `local` entries on this rank, on communicator `comm`.
    pub fn new(comm: Comm, local: usize) -> Result<Vector> {
        let mut v: ffi::Vec = ptr::null_mut();
        call!(VecCreateMPI(comm.0, local as Int, PETSC_DETERMINE, &mut v))?;
        Ok(Vector(v))
    }

    pub fn duplicate(&self) -> Result<Vector> {
        let mut v: ffi::Vec = ptr::null_mut();
        call!(VecDuplicate(self.0, &mut v))?;
        Ok(Vector(v))
    }

    pub fn local_len(&self) -> Result<usize> {
        let mut n: Int = 0;
        call!(VecGetLocalSize(self.0, &mut n))?;
        Ok(n as usize)
    }

    /// Copy the local part out.
    pub fn to_vec(&self) -> Result<Vec<f64>> {
        let n = self.local_len()?;
        let mut a: *const f64 = ptr::null();
        call!(VecGetArrayRead(self.0, &mut a))?;
        // SAFETY: PETSc gives `n` readable entries until the restore below.
        let out = unsafe { std::slice::from_raw_parts(a, n) }.to_vec();
        call!(VecRestoreArrayRead(self.0, &mut a))?;
        Ok(out)
    }

    /// The largest absolute entry over every rank (collective).
    pub fn norm_inf(&self) -> Result<f64> {
        let mut n = 0.0;
        call!(VecNorm(self.0, ffi::NORM_INFINITY, &mut n))?;
        Ok(n)
    }

    /// Overwrite the local part.
    pub fn copy_from(&mut self, values: &[f64]) -> Result<()> {
        let n = self.local_len()?;
        assert_eq!(n, values.len(), "vector length mismatch");
        let mut a: *mut f64 = ptr::null_mut();
        call!(VecGetArray(self.0, &mut a))?;
        // SAFETY: PETSc gives `n` writable entries until the restore below.
        unsafe { std::slice::from_raw_parts_mut(a, n) }.copy_from_slice(values);
        call!(VecRestoreArray(self.0, &mut a))
    }
}

/// Copies chosen global entries of a distributed vector to every rank (a `VecScatter` onto
/// a sequential vector): the whole vector, or a few rows such as the Γc dofs.
pub struct Gather {
    scatter: ffi::VecScatter,
    out: Vector,
    _is: Is,
}

impl Gather {
    /// Gather the global `rows` of vectors laid out like `like` (every rank asks for the same
    /// rows, in this order).
    pub fn new(like: &Vector, rows: &[Int]) -> Result<Gather> {
        let self_comm = Petsc::comm_self();
        let is = Is::new(self_comm, rows)?;
        let mut v: ffi::Vec = ptr::null_mut();
        call!(VecCreateSeq(self_comm.0, rows.len() as Int, &mut v))?;
        let out = Vector(v);
        let mut scatter: ffi::VecScatter = ptr::null_mut();
        call!(VecScatterCreate(
            like.0,
            is.0,
            out.0,
            ptr::null_mut(),
            &mut scatter
        ))?;
        Ok(Gather {
            scatter,
            out,
            _is: is,
        })
    }

    /// The gathered entries of `x` (collective over `x`'s communicator).
    pub fn gather(&mut self, x: &Vector) -> Result<Vec<f64>> {
        self.gather_raw(x.0)
    }

    fn gather_raw(&mut self, x: ffi::Vec) -> Result<Vec<f64>> {
        call!(VecScatterBegin(
            self.scatter,
            x,
            self.out.0,
            ffi::INSERT_VALUES,
            ffi::SCATTER_FORWARD
        ))?;
        call!(VecScatterEnd(
            self.scatter,
            x,
            self.out.0,
            ffi::INSERT_VALUES,
            ffi::SCATTER_FORWARD
        ))?;
        self.out.to_vec()
    }
}

impl Drop for Gather {
    fn drop(&mut self) {
        unsafe { ffi::VecScatterDestroy(&mut self.scatter) };
    }
}

impl Drop for Vector {
    fn drop(&mut self) {
        unsafe { ffi::VecDestroy(&mut self.0) };
    }
}

// ---------------------------------------------------------------------------------------------
// Matrices

/// A PETSc AIJ matrix (SeqAIJ or MPIAIJ depending on the communicator size).
pub struct Matrix(ffi::Mat);

impl Matrix {
    /// ‖A‖∞, the largest absolute row sum (collective).
    pub fn norm_inf(&self) -> Result<f64> {
        let mut n = 0.0;
        call!(MatNorm(self.0, ffi::NORM_INFINITY, &mut n))?;
        Ok(n)
    }

    /// An AIJ matrix (block size 2) with `local_rows` rows on this rank, to be filled by
    /// [`Matrix::add_values`]: `d_nnz[i]` / `o_nnz[i]` are the nonzeros of local row i in the
    /// diagonal block (columns owned here) and off it (the exact counts: a missing one is an error).
    pub fn preallocated(
        comm: Comm,
        local_rows: usize,
        d_nnz: &[Int],
        o_nnz: &[Int],
    ) -> Result<Matrix> {
        assert!(d_nnz.len() == local_rows && o_nnz.len() == local_rows);
        let mut m: ffi::Mat = ptr::null_mut();
        call!(MatCreate(comm.0, &mut m))?;
        let mat = Matrix(m);
        let n = local_rows as Int;
        call!(MatSetSizes(mat.0, n, n, PETSC_DETERMINE, PETSC_DETERMINE))?;
        call!(MatSetBlockSize(mat.0, 2))?;
        let aij = cstr("aij");
        call!(MatSetType(mat.0, aij.as_ptr()))?;
        call!(MatSeqAIJSetPreallocation(mat.0, 0, d_nnz.as_ptr()))?;
        call!(MatMPIAIJSetPreallocation(
            mat.0,
            0,
            d_nnz.as_ptr(),
            0,
            o_nnz.as_ptr()
        ))?;
        Ok(mat)
    }

    /// Add the dense block `vals` (row-major, rows × cols) at global `rows`, `cols`; rows of
    /// other ranks are sent to their owners by [`Matrix::assemble`].
    pub fn add_values(&mut self, rows: &[Int], cols: &[Int], vals: &[f64]) -> Result<()> {
        assert_eq!(rows.len() * cols.len(), vals.len());
        call!(MatSetValues(
            self.0,
            rows.len() as Int,
            rows.as_ptr(),
            cols.len() as Int,
            cols.as_ptr(),
            vals.as_ptr(),
            ffi::ADD_VALUES
        ))
    }

    /// Final assembly (collective), then mark the stiffness symmetric positive definite.
    pub fn assemble(&mut self) -> Result<()> {
        call!(MatAssemblyBegin(self.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyEnd(self.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatSetOption(self.0, ffi::MAT_SYMMETRIC, ffi::PETSC_TRUE))?;
        call!(MatSetOption(self.0, ffi::MAT_SPD, ffi::PETSC_TRUE))
    }

    /// Attach a near null space (for GAMG) spanned by `modes`: this rank's parts (in the
    /// matrix's row order) of orthonormal vectors.
    pub fn set_near_null_space(&mut self, comm: Comm, modes: &[Vec<f64>]) -> Result<()> {
        let vecs = modes
            .iter()
            .map(|m| {
                let mut v = Vector::new(comm, m.len())?;
                call!(VecSetBlockSize(v.0, 2))?;
                v.copy_from(m)?;
                Ok(v)
            })
            .collect::<Result<Vec<Vector>>>()?;
        let raw: Vec<ffi::Vec> = vecs.iter().map(|v| v.0).collect();
        let mut ns: ffi::MatNullSpace = ptr::null_mut();
        call!(MatNullSpaceCreate(
            comm.0,
            ffi::PETSC_FALSE,
            raw.len() as Int,
            raw.as_ptr(),
            &mut ns
        ))?;
        let set = call!(MatSetNearNullSpace(self.0, ns));
        unsafe { ffi::MatNullSpaceDestroy(&mut ns) };
        set
    }

    pub fn duplicate(&self) -> Result<Matrix> {
        let mut m: ffi::Mat = ptr::null_mut();
        call!(MatDuplicate(self.0, ffi::MAT_COPY_VALUES, &mut m))?;
        Ok(Matrix(m))
    }

    /// Zero the given global rows and columns, putting `diag` on the diagonal: symmetric
    /// elimination of Dirichlet conditions (the right-hand side is lifted by the caller).
    pub fn zero_rows_columns(&mut self, rows: &[Int], diag: f64) -> Result<()> {
        call!(MatZeroRowsColumns(
            self.0,
            rows.len() as Int,
            rows.as_ptr(),
            diag,
            ptr::null_mut(),
            ptr::null_mut()
        ))?;
        // The elimination keeps the matrix SPD; tell the factorisation again.
        call!(MatSetOption(self.0, ffi::MAT_SPD, ffi::PETSC_TRUE))
    }

    /// y = A x.
    pub fn mult(&self, x: &Vector, y: &mut Vector) -> Result<()> {
        call!(MatMult(self.0, x.0, y.0))
    }
}

impl Drop for Matrix {
    fn drop(&mut self) {
        unsafe { ffi::MatDestroy(&mut self.0) };
    }
}

// ---------------------------------------------------------------------------------------------
// Linear solvers

/// What a solve did.
#[derive(Clone, Copy, Debug)]
pub struct SolveInfo {
    pub iterations: i64,
    pub reason: i32,
    /// The normwise backward error of the solution, ‖b − A x‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞): about
    /// 1e−16 for a stable factorisation whatever the condition of A, at most the relative
    /// residual for an iterative solve ([`Ksp::backward_error`]).
    pub backward_error: f64,
}

/// A KSP with its operator; configured by defaults (a direct Cholesky factorisation by MUMPS)
/// that the options database (`-<prefix>ksp_type`, `-<prefix>pc_type`, …) overrides.
pub struct Ksp {
    ksp: ffi::KSP,
    _mat: Matrix,
    schur: Option<Vec<f64>>,
    prefix: String,
    /// ‖A‖∞, once computed.
    a_norm: std::cell::Cell<Option<f64>>,
    /// Seconds spent computing backward errors.
    check_seconds: std::cell::Cell<f64>,
}

impl Ksp {
    /// Create the solver for `mat` with options prefix `prefix` (e.g. `body1_`). When
    /// `schur_rows` is given and the factorisation is MUMPS, its Schur complement on those rows
    /// is computed during the factorisation ([`Ksp::schur_complement`]).
    pub fn new(comm: Comm, mat: Matrix, prefix: &str, schur_rows: Option<&[Int]>) -> Result<Ksp> {
        let mut ksp: ffi::KSP = ptr::null_mut();
        call!(KSPCreate(comm.0, &mut ksp))?;
        let mut solver = Ksp {
            ksp,
            _mat: mat,
            schur: None,
            prefix: prefix.to_string(),
            a_norm: std::cell::Cell::new(None),
            check_seconds: std::cell::Cell::new(0.0),
        };
        call!(KSPSetOperators(solver.ksp, solver._mat.0, solver._mat.0))?;
        let p = cstr(prefix);
        call!(KSPSetOptionsPrefix(solver.ksp, p.as_ptr()))?;
        let preonly = cstr("preonly");
        call!(KSPSetType(solver.ksp, preonly.as_ptr()))?;
        let mut pc: ffi::PC = ptr::null_mut();
        call!(KSPGetPC(solver.ksp, &mut pc))?;
        let chol = cstr("cholesky");
        call!(PCSetType(pc, chol.as_ptr()))?;
        let mumps = cstr("mumps");
        call!(PCFactorSetMatSolverType(pc, mumps.as_ptr()))?;
        // `-<prefix>pc_type lu` (or `cholesky`) alone makes a new PC, which forgets the
        // package set above (and may create its factor before it could be set again): MUMPS
        // stays the default unless `-<prefix>pc_factor_mat_solver_type` names another.
        let pc_option = option_string(&format!("-{prefix}pc_type"))?;
        if matches!(pc_option.as_deref(), Some("lu" | "cholesky")) {
            option_default(&format!("-{prefix}pc_factor_mat_solver_type"), "mumps")?;
        }
        call!(KSPSetFromOptions(solver.ksp))?;
        let mut factor: ffi::Mat = ptr::null_mut();
        let mut schur_is = None;
        if let Some(rows) = schur_rows {
            if solver.uses_mumps_factor(pc)? {
                call!(PCFactorSetUpMatSolverType(pc))?;
                call!(PCFactorGetMatrix(pc, &mut factor))?;
                let is = Is::new(comm, rows)?;
                call!(MatFactorSetSchurIS(factor, is.0))?;
                schur_is = Some((is, rows.len()));
            }
        }
        call!(KSPSetUp(solver.ksp))?;
        if let Some((_is, m)) = schur_is {
            let mut s: ffi::Mat = ptr::null_mut();
            let mut status = ffi::MAT_FACTOR_SCHUR_UNFACTORED;
            call!(MatFactorCreateSchurComplement(factor, &mut s, &mut status))?;
            let s = Matrix(s);
            let mut a: *const f64 = ptr::null();
            call!(MatDenseGetArrayRead(s.0, &mut a))?;
            // SAFETY: a sequential dense m x m matrix, column-major.
            let dense = unsafe { std::slice::from_raw_parts(a, m * m) }.to_vec();
            call!(MatDenseRestoreArrayRead(s.0, &mut a))?;
            solver.schur = Some(dense);
        }
        Ok(solver)
    }

    /// The PC's type name.
    fn pc_type(pc: ffi::PC) -> Result<String> {
        let mut t: ffi::PCType = ptr::null();
        call!(PCGetType(pc, &mut t))?;
        if t.is_null() {
            return Ok(String::new());
        }
        // SAFETY: PETSc's type names are static, NUL-terminated strings.
        Ok(unsafe { CStr::from_ptr(t) }.to_string_lossy().into_owned())
    }

    /// Whether the PC is a factorisation (`cholesky` or `lu`).
    fn is_factorisation(&self, pc: ffi::PC) -> Result<bool> {
        Ok(matches!(Self::pc_type(pc)?.as_str(), "cholesky" | "lu"))
    }

    /// The factorisation's package (`mumps`, `petsc`, `superlu_dist`…), when one is set.
    fn solver_package(&self, pc: ffi::PC) -> Result<Option<String>> {
        let mut t: ffi::MatSolverType = ptr::null();
        call!(PCFactorGetMatSolverType(pc, &mut t))?;
        if t.is_null() {
            return Ok(None);
        }
        // SAFETY: as in `pc_type`.
        Ok(Some(
            unsafe { CStr::from_ptr(t) }.to_string_lossy().into_owned(),
        ))
    }

    fn uses_mumps_factor(&self, pc: ffi::PC) -> Result<bool> {
        Ok(self.is_factorisation(pc)? && self.solver_package(pc)?.as_deref() == Some("mumps"))
    }

    /// The KSP's and the PC's type names (`preonly`, `cholesky`…), for messages.
    pub fn types(&self) -> Result<(String, String)> {
        let mut t: ffi::KSPType = ptr::null();
        call!(KSPGetType(self.ksp, &mut t))?;
        // SAFETY: as in `pc_type`.
        let ksp = unsafe { CStr::from_ptr(t) }.to_string_lossy().into_owned();
        let mut pc: ffi::PC = ptr::null_mut();
        call!(KSPGetPC(self.ksp, &mut pc))?;
        Ok((ksp, Self::pc_type(pc)?))
    }

    /// The KSP's relative tolerance (`-<prefix>ksp_rtol`).
    pub fn rtol(&self) -> Result<f64> {
        let (mut rtol, mut abstol, mut dtol, mut maxits) = (0.0, 0.0, 0.0, 0 as Int);
        call!(KSPGetTolerances(
            self.ksp,
            &mut rtol,
            &mut abstol,
            &mut dtol,
            &mut maxits
        ))?;
        Ok(rtol)
    }

    /// ‖A‖∞ (computed once).
    fn a_norm(&self) -> Result<f64> {
        if let Some(n) = self.a_norm.get() {
            return Ok(n);
        }
        let mut n = 0.0;
        call!(MatNorm(self._mat.0, ffi::NORM_INFINITY, &mut n))?;
        self.a_norm.set(Some(n));
        Ok(n)
    }

    /// The normwise backward error of x as a solution of A x = b,
    /// ‖b − A x‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞) (Rigal & Gaches; Higham, *Accuracy and Stability of
    /// Numerical Algorithms*, Thm. 7.1): the smallest relative change of A and b of which x is
    /// the exact solution. A stable factorisation gives about the machine epsilon whatever the
    /// condition of A; a preconditioner applied once (`preonly` with a non-direct PC) gives
    /// orders of magnitude more. Collective; NaN when x is not finite.
    pub fn backward_error(&self, b: &Vector, x: &Vector) -> Result<f64> {
        let t = std::time::Instant::now();
        let r = b.duplicate()?;
        call!(MatMult(self._mat.0, x.0, r.0))?;
        call!(VecAXPY(r.0, -1.0, b.0))?;
        let (rn, xn, bn) = (r.norm_inf()?, x.norm_inf()?, b.norm_inf()?);
        let e = ratio(rn, self.a_norm()? * xn + bn);
        self.add_check_time(t);
        Ok(e)
    }

    fn add_check_time(&self, since: std::time::Instant) {
        self.check_seconds
            .set(self.check_seconds.get() + since.elapsed().as_secs_f64());
    }

    /// Seconds this solver spent computing the backward errors of its solves.
    pub fn check_seconds(&self) -> f64 {
        self.check_seconds.get()
    }

    /// The worst backward error of the columns of X as solutions of A X = B (dense
    /// matrices with A's row layout). Collective.
    fn backward_error_columns(&self, b: &Matrix, x: &Matrix, columns: usize) -> Result<f64> {
        let t = std::time::Instant::now();
        let mut r: ffi::Mat = ptr::null_mut();
        call!(MatMatMult(
            self._mat.0,
            x.0,
            ffi::MAT_INITIAL_MATRIX,
            -2.0, // PETSC_DEFAULT
            &mut r
        ))?;
        let r = Matrix(r);
        call!(MatAXPY(r.0, -1.0, b.0, ffi::SAME_NONZERO_PATTERN))?;
        let norms = |m: &Matrix| -> Result<Vec<f64>> {
            let mut n = vec![0.0; columns];
            call!(MatGetColumnNorms(m.0, ffi::NORM_INFINITY, n.as_mut_ptr()))?;
            Ok(n)
        };
        let (rn, xn, bn) = (norms(&r)?, norms(x)?, norms(b)?);
        let a = self.a_norm()?;
        let e = (0..columns)
            .map(|c| ratio(rn[c], a * xn[c] + bn[c]))
            .fold(0.0, worst);
        self.add_check_time(t);
        Ok(e)
    }

    /// The dense Schur complement computed during factorisation (column-major, symmetric part
    /// completed), if MUMPS computed one.
    pub fn schur_complement(&self) -> Option<&[f64]> {
        self.schur.as_deref()
    }

    /// The factored matrix of the PC when it is a MUMPS factorisation (after setup).
    fn mumps_factor(&self) -> Result<Option<ffi::Mat>> {
        let mut pc: ffi::PC = ptr::null_mut();
        call!(KSPGetPC(self.ksp, &mut pc))?;
        if !self.is_direct()? || !self.uses_mumps_factor(pc)? {
            return Ok(None);
        }
        let mut factor: ffi::Mat = ptr::null_mut();
        call!(PCFactorGetMatrix(pc, &mut factor))?;
        Ok(Some(factor))
    }

    /// Whether the solver is a MUMPS factorisation applied once (`preonly`).
    pub fn has_mumps_factor(&self) -> Result<bool> {
        Ok(self.mumps_factor()?.is_some())
    }

    /// MUMPS's count of the floating-point operations of its factorisation (RINFOG(3), over
    /// every rank of the communicator), when the solver is a MUMPS factorisation.
    pub fn mumps_factorisation_flops(&self) -> Result<Option<f64>> {
        let Some(f) = self.mumps_factor()? else {
            return Ok(None);
        };
        let mut flops = 0.0;
        call!(MatMumpsGetRinfog(f, 3, &mut flops))?;
        Ok(Some(flops))
    }

    /// The block (A⁻¹)[rows, rows] (column-major) from MUMPS's computation of selected
    /// entries of the inverse (ICNTL(30)) with the factorisation already made: sparse
    /// right-hand sides and a pruned elimination tree, on any number of ranks. Collective;
    /// the block arrives on the communicator's first rank (`root`), `None` elsewhere, and
    /// `None` everywhere when the solver is not a MUMPS factorisation.
    pub fn mumps_inverse_block(
        &self,
        comm: Comm,
        root: bool,
        rows: &[Int],
    ) -> Result<Option<Vec<f64>>> {
        let Some(f) = self.mumps_factor()? else {
            return Ok(None);
        };
        let m = rows.len();
        let (mut n, mut cols) = (0 as Int, 0 as Int);
        call!(MatGetSize(self._mat.0, &mut n, &mut cols))?;
        // The pattern (the transpose of the wanted entries, which is the same set) lives whole
        // in the first rank's diagonal block: PETSc hands that block's CSR to MUMPS.
        let local = if root { n } else { 0 };
        let mut nnz = vec![0 as Int; local as usize];
        if root {
            for &r in rows {
                nnz[r as usize] = m as Int;
            }
        }
        let zeros = vec![0 as Int; local as usize];
        let mut bt: ffi::Mat = ptr::null_mut();
        call!(MatCreateAIJ(
            comm.0,
            local,
            local,
            n,
            n,
            0,
            nnz.as_ptr(),
            0,
            zeros.as_ptr(),
            &mut bt
        ))?;
        let bt = Matrix(bt);
        drop((nnz, zeros));
        if root {
            let ones = vec![1.0; m];
            for &r in rows {
                call!(MatSetValues(
                    bt.0,
                    1,
                    &r,
                    m as Int,
                    rows.as_ptr(),
                    ones.as_ptr(),
                    ffi::INSERT_VALUES
                ))?;
            }
        }
        call!(MatAssemblyBegin(bt.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyEnd(bt.0, ffi::MAT_FINAL_ASSEMBLY))?;
        // PETSc leaves ICNTL(30) = 1 (entries of the inverse) and ICNTL(21) = 0 (centralised
        // solution) set after the call, and its solves set neither: restore both.
        let (mut icntl21, mut icntl27, mut icntl30) = (0 as Int, 0 as Int, 0 as Int);
        call!(MatMumpsGetIcntl(f, 21, &mut icntl21))?;
        call!(MatMumpsGetIcntl(f, 27, &mut icntl27))?;
        call!(MatMumpsGetIcntl(f, 30, &mut icntl30))?;
        // All the columns in one block (ICNTL(27), MUMPS's default is 32 at most): the pruned
        // tree is then traversed once (paper n = 256 on 2 ranks: 0.50 → 0.24 s), unless the
        // user chose a block size.
        if !option_present(&format!("-{}mat_mumps_icntl_27", self.prefix)) {
            call!(MatMumpsSetIcntl(f, 27, (m as Int).clamp(1, INVERSE_BLOCK)))?;
        }
        let inverse = call!(MatMumpsGetInverseTranspose(f, bt.0));
        call!(MatMumpsSetIcntl(f, 21, icntl21))?;
        call!(MatMumpsSetIcntl(f, 27, icntl27))?;
        call!(MatMumpsSetIcntl(f, 30, icntl30))?;
        inverse?;
        if !root {
            return Ok(None);
        }
        let position: std::collections::HashMap<Int, usize> =
            rows.iter().enumerate().map(|(k, &r)| (r, k)).collect();
        let mut out = vec![0.0; m * m];
        for (j, &r) in rows.iter().enumerate() {
            let mut len: Int = 0;
            let mut idx: *const Int = ptr::null();
            let mut vals: *const f64 = ptr::null();
            call!(MatGetRow(bt.0, r, &mut len, &mut idx, &mut vals))?;
            // SAFETY: PETSc gives `len` column indices and values until MatRestoreRow.
            let (idx_s, vals_s) = unsafe {
                (
                    std::slice::from_raw_parts(idx, len as usize),
                    std::slice::from_raw_parts(vals, len as usize),
                )
            };
            for (c, v) in idx_s.iter().zip(vals_s) {
                if let Some(&i) = position.get(c) {
                    out[j * m + i] = *v;
                }
            }
            call!(MatRestoreRow(bt.0, r, &mut len, &mut idx, &mut vals))?;
        }
        Ok(Some(out))
    }

    /// The block (A⁻¹)[rows, rows] (column-major), from the solves A X = E with the unit
    /// vectors of `rows`, `batch` right-hand sides at a time (`KSPMatSolve`: one multiple-RHS
    /// solve per batch with MUMPS, one solve per column otherwise). `owned` is this rank's row
    /// range, `local_rows` its length; `gather` gathers exactly `rows`. Returns the block and
    /// the worst converged reason.
    pub fn inverse_block(
        &self,
        comm: Comm,
        owned: std::ops::Range<Int>,
        rows: &[Int],
        gather: &mut Gather,
        batch: usize,
    ) -> Result<(Vec<f64>, i32, f64)> {
        let m = rows.len();
        let local = owned.end - owned.start;
        let mut out = vec![0.0; m * m];
        let mut reason = 1;
        let mut backward = 0.0;
        for first in (0..m).step_by(batch.max(1)) {
            let nb = batch.max(1).min(m - first);
            let dense = |values: bool| -> Result<Matrix> {
                let mut b: ffi::Mat = ptr::null_mut();
                call!(MatCreateDense(
                    comm.0,
                    local,
                    -1,
                    PETSC_DETERMINE,
                    nb as Int,
                    ptr::null_mut(),
                    &mut b
                ))?;
                let b = Matrix(b);
                if values {
                    for c in 0..nb {
                        let row = rows[first + c];
                        if owned.contains(&row) {
                            let col = c as Int;
                            call!(MatSetValues(
                                b.0,
                                1,
                                &row,
                                1,
                                &col,
                                &1.0,
                                ffi::INSERT_VALUES
                            ))?;
                        }
                    }
                }
                call!(MatAssemblyBegin(b.0, ffi::MAT_FINAL_ASSEMBLY))?;
                call!(MatAssemblyEnd(b.0, ffi::MAT_FINAL_ASSEMBLY))?;
                Ok(b)
            };
            let (e, x) = (dense(true)?, dense(false)?);
            call!(KSPMatSolve(self.ksp, e.0, x.0))?;
            let mut r = ffi::KSP_CONVERGED_ITERATING;
            call!(KSPGetConvergedReason(self.ksp, &mut r))?;
            reason = reason.min(r);
            backward = worst(backward, self.backward_error_columns(&e, &x, nb)?);
            for c in 0..nb {
                let mut v: ffi::Vec = ptr::null_mut();
                call!(MatDenseGetColumnVecRead(x.0, c as Int, &mut v))?;
                let col = gather.gather_raw(v);
                call!(MatDenseRestoreColumnVecRead(x.0, c as Int, &mut v))?;
                out[(first + c) * m..(first + c + 1) * m].copy_from_slice(&col?);
            }
        }
        Ok((out, reason, backward))
    }

    /// Whether the solver is a factorisation applied once (`preonly`).
    pub fn is_direct(&self) -> Result<bool> {
        let mut t: ffi::KSPType = ptr::null();
        call!(KSPGetType(self.ksp, &mut t))?;
        Ok(unsafe { CStr::from_ptr(t) }.to_bytes() == b"preonly")
    }

    /// Solve A X = B for the columns of B. A factorisation (`preonly`) solves them at once
    /// (`KSPMatSolve`: one multiple-right-hand-side solve, which reads the factor once); an
    /// iterative solver one by one, so that each column's convergence is checked. `columns`
    /// are this rank's rows of B's columns, each `local` long; returns this rank's rows of X's
    /// columns and the worst converged reason.
    pub fn solve_many(
        &self,
        comm: Comm,
        columns: &[Vec<f64>],
    ) -> Result<(Vec<Vec<f64>>, i32, f64)> {
        if !self.is_direct()? {
            let (mut reason, mut backward) = (1, 0.0);
            let mut out = Vec::with_capacity(columns.len());
            for col in columns {
                let mut b = Vector::new(comm, col.len())?;
                b.copy_from(col)?;
                let mut x = b.duplicate()?;
                let info = self.solve(&b, &mut x)?;
                reason = reason.min(info.reason);
                backward = worst(backward, info.backward_error);
                out.push(x.to_vec()?);
            }
            return Ok((out, reason, backward));
        }
        let nb = columns.len();
        let local = columns.first().map_or(0, |c| c.len());
        let dense = || -> Result<Matrix> {
            let mut m: ffi::Mat = ptr::null_mut();
            call!(MatCreateDense(
                comm.0,
                local as Int,
                -1,
                PETSC_DETERMINE,
                nb as Int,
                ptr::null_mut(),
                &mut m
            ))?;
            Ok(Matrix(m))
        };
        let (b, x) = (dense()?, dense()?);
        let mut a: *mut f64 = ptr::null_mut();
        call!(MatDenseGetArray(b.0, &mut a))?;
        // SAFETY: a dense matrix PETSc allocated with `local` rows and `nb` columns on this
        // rank, column-major with leading dimension `local`, writable until the restore.
        let values = unsafe { std::slice::from_raw_parts_mut(a, local * nb) };
        for (c, col) in columns.iter().enumerate() {
            assert_eq!(col.len(), local, "right-hand side length mismatch");
            values[c * local..(c + 1) * local].copy_from_slice(col);
        }
        call!(MatDenseRestoreArray(b.0, &mut a))?;
        call!(MatAssemblyBegin(b.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyEnd(b.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyBegin(x.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(MatAssemblyEnd(x.0, ffi::MAT_FINAL_ASSEMBLY))?;
        call!(KSPMatSolve(self.ksp, b.0, x.0))?;
        let mut reason = ffi::KSP_CONVERGED_ITERATING;
        call!(KSPGetConvergedReason(self.ksp, &mut reason))?;
        let backward = self.backward_error_columns(&b, &x, nb)?;
        let mut r: *const f64 = ptr::null();
        call!(MatDenseGetArrayRead(x.0, &mut r))?;
        // SAFETY: as above, readable until the restore.
        let values = unsafe { std::slice::from_raw_parts(r, local * nb) };
        let out = (0..nb)
            .map(|c| values[c * local..(c + 1) * local].to_vec())
            .collect();
        call!(MatDenseRestoreArrayRead(x.0, &mut r))?;
        Ok((out, reason, backward))
    }

    /// Solve A x = b.
    pub fn solve(&self, b: &Vector, x: &mut Vector) -> Result<SolveInfo> {
        call!(KSPSolve(self.ksp, b.0, x.0))?;
        let mut reason = ffi::KSP_CONVERGED_ITERATING;
        call!(KSPGetConvergedReason(self.ksp, &mut reason))?;
        let mut its: Int = 0;
        call!(KSPGetIterationNumber(self.ksp, &mut its))?;
        Ok(SolveInfo {
            iterations: its as i64,
            reason,
            backward_error: self.backward_error(b, x)?,
        })
    }
}

/// a / b, NaN when either is not finite (a solution that overflowed has no backward error).
fn ratio(a: f64, b: f64) -> f64 {
    if a.is_finite() && b.is_finite() {
        if b > 0.0 {
            a / b
        } else {
            0.0
        }
    } else {
        f64::NAN
    }
}

/// The worse of two backward errors, NaN (not finite) the worst.
fn worst(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

impl Drop for Ksp {
    fn drop(&mut self) {
        unsafe { ffi::KSPDestroy(&mut self.ksp) };
    }
}
