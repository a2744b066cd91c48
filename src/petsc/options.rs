//! The options database: single options read or set, the options given but not read, and
//! [`OptionsBlock`], the registered options that `-help` lists.

use std::ffi::CStr;
use std::os::raw::c_char;
use std::ptr;

use super::comm::Comm;
use super::error::{call, cstr, Result};
use super::{ffi, Int};

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
    set_option(name, value)
}

/// Sets option `name` to `value` in the options database, over any value it had.
pub fn set_option(name: &str, value: &str) -> Result<()> {
    let (n, v) = (cstr(name), cstr(value));
    call!(PetscOptionsSetValue(
        ptr::null_mut(),
        n.as_ptr(),
        v.as_ptr()
    ))
}

/// Removes option `name` from the options database (nothing where it is absent).
pub fn clear_option(name: &str) -> Result<()> {
    let n = cstr(name);
    call!(PetscOptionsClearValue(ptr::null_mut(), n.as_ptr()))
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

    /// A real option, registered with its help text and default, and whether it was given
    /// (given without a value, it reads as not given: see `readers.rs`).
    pub(super) fn read_real(
        &mut self,
        name: &str,
        help: &str,
        default: f64,
    ) -> Result<(f64, bool)> {
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

    /// An integer option, as [`OptionsBlock::read_real`].
    pub(super) fn read_int(&mut self, name: &str, help: &str, default: i64) -> Result<(i64, bool)> {
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

    /// A string option, as [`OptionsBlock::read_real`] (given without a value, it reads as
    /// given and empty).
    pub(super) fn read_string(
        &mut self,
        name: &str,
        help: &str,
        default: &str,
    ) -> Result<(String, bool)> {
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
