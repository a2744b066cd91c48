//! The HDF5 C calls of a collective write that the `hdf5` crate does not make: it writes with
//! the default transfer property list (independent I/O in parallel) and skips empty
//! selections, while a collective write needs a collective transfer list and every rank in
//! `H5Dwrite`. The calls are hdf5-metno-sys's typed declarations, of the libhdf5 the `hdf5`
//! crate links.

use std::ops::Range;

use hdf5_metno_sys::h5::herr_t;
use hdf5_metno_sys::h5::hsize_t;
use hdf5_metno_sys::h5d::H5Dwrite;
use hdf5_metno_sys::h5i::hid_t;
use hdf5_metno_sys::h5p::{H5FD_mpio_xfer_t, H5Pcreate, H5Pset_dxpl_mpio};
use hdf5_metno_sys::h5s::{H5S_seloper_t, H5Sselect_hyperslab, H5Sselect_none};

/// The error of a failed HDF5 C call: the library's error stack.
fn h5_error() -> hdf5::Error {
    hdf5::Error::query().unwrap_or_else(|e| e)
}

fn h5check(code: herr_t) -> hdf5::Result<()> {
    if code < 0 {
        Err(h5_error())
    } else {
        Ok(())
    }
}

/// A data transfer property list asking for collective MPI-IO.
pub(super) fn collective_transfer() -> hdf5::Result<hdf5::PropertyList> {
    hdf5::sync::sync(|| {
        // SAFETY: plain HDF5 calls on a property list this function owns.
        unsafe {
            let id = H5Pcreate(*hdf5::globals::H5P_DATASET_XFER);
            if id < 0 {
                return Err(h5_error());
            }
            let plist: hdf5::PropertyList = hdf5::from_id(id)?;
            h5check(H5Pset_dxpl_mpio(
                plist.id(),
                H5FD_mpio_xfer_t::H5FD_MPIO_COLLECTIVE,
            ))?;
            Ok(plist)
        }
    })
}

/// This rank's rows of a dataset: the file selection and the memory space
/// (none for no rows: the empty file selection serves as both).
pub(super) struct RowSelection {
    file: hdf5::Dataspace,
    memory: Option<hdf5::Dataspace>,
}

impl RowSelection {
    /// Rows `rows` (first dimension, all of the others) of `ds`, to be
    /// written from `len` values.
    pub(super) fn new(
        ds: &hdf5::Dataset,
        rows: Range<usize>,
        len: usize,
    ) -> hdf5::Result<RowSelection> {
        let file = ds.space()?;
        let mut count: Vec<usize> = file.shape();
        if count.is_empty() || rows.end > count[0] {
            return Err(format!("rows {rows:?} outside shape {count:?}").into());
        }
        count[0] = rows.len();
        if count.iter().product::<usize>() != len {
            return Err(format!("{len} values for {count:?} entries").into());
        }
        if rows.is_empty() {
            // SAFETY: `file` is a dataspace this function owns.
            h5check(hdf5::sync::sync(|| unsafe { H5Sselect_none(file.id()) }))?;
            return Ok(RowSelection { file, memory: None });
        }
        let memory = hdf5::Dataspace::try_new(count.clone())?;
        let mut start = vec![0 as hsize_t; count.len()];
        start[0] = rows.start as hsize_t;
        let count: Vec<hsize_t> = count.iter().map(|&c| c as hsize_t).collect();
        // SAFETY: `start` and `count` have the rank of `file`; null stride
        // and block mean 1.
        h5check(hdf5::sync::sync(|| unsafe {
            H5Sselect_hyperslab(
                file.id(),
                H5S_seloper_t::H5S_SELECT_SET,
                start.as_ptr(),
                std::ptr::null(),
                count.as_ptr(),
                std::ptr::null(),
            )
        }))?;
        Ok(RowSelection {
            file,
            memory: Some(memory),
        })
    }

    /// `H5Dwrite` of `data` (as many values as selected) with transfer list
    /// `xfer`: collective when `xfer` says so, so every rank calls it.
    pub(super) fn write<T: hdf5::H5Type>(
        &self,
        ds: &hdf5::Dataset,
        data: &[T],
        xfer: hid_t,
    ) -> hdf5::Result<()> {
        let dtype = hdf5::Datatype::from_type::<T>()?;
        let memory = self.memory.as_ref().unwrap_or(&self.file);
        // SAFETY: `data` holds exactly the selected number of `T`s (checked
        // in `new`), laid out as the memory space says; the ids are alive.
        h5check(hdf5::sync::sync(|| unsafe {
            H5Dwrite(
                ds.id(),
                dtype.id(),
                memory.id(),
                self.file.id(),
                xfer,
                data.as_ptr().cast(),
            )
        }))
    }
}
