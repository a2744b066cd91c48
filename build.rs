//! Generates the PETSc bindings (`$OUT_DIR/petsc_bindings.rs`) against Debian's PETSc 3.18
//! (found through pkg-config `PETSc`) and OpenMPI's `mpi.h` (pkg-config `ompi-c`).
//! Only what `src/petsc/` uses is allowlisted: full bindings cost seconds per rebuild.

use std::env;
use std::path::PathBuf;

const FUNCTIONS: &[&str] = &[
    "PetscInitialize",
    "PetscFinalize",
    "PetscInitialized",
    "PetscPushErrorHandler",
    "PetscReturnErrorHandler",
    "PetscErrorMessage",
    "PetscOptions(Begin|End|Real|Int|String|Bool)_Private",
    "PetscOptionsHasName",
    "PetscOptionsGetString",
    "PetscOptionsSetValue",
    "PetscOptionsClearValue",
    "PetscOptionsLeft(Get|Restore)?",
    "PetscLogStageRegister",
    "PetscLogStagePush",
    "PetscLogStagePop",
    "PetscMemoryGetMaximumUsage",
    "PetscMemorySetGetMaximumUsage",
    "PetscObjectSetName",
    "PetscObjectReference",
    "PetscFreeA",
    "PetscOptionsGetAll",
    "ISCreateGeneral",
    "ISDestroy",
    "Vec(Create|CreateMPI|CreateSeq|Destroy|Duplicate|Set|SetBlockSize|GetSize|GetLocalSize|GetOwnershipRange|GetArray|RestoreArray|GetArrayRead|RestoreArrayRead|Norm|AXPY|Copy|SetUp)",
    "Mat(Create|SetSizes|SetType|SetFromOptions|SetUp|Destroy|Duplicate|Mult|MultAdd|ZeroRowsColumns|SetOption|SetBlockSize|GetSize|GetLocalSize|GetOwnershipRange|AssemblyBegin|AssemblyEnd|DenseGetArrayRead|DenseRestoreArrayRead|DenseGetArray|DenseRestoreArray|FactorSetSchurIS|FactorCreateSchurComplement|SetOptionsPrefix|GetInfo|SetValues|SetNearNullSpace|CreateDense|DenseGetColumnVecRead|DenseRestoreColumnVecRead|Norm|MatMult|AXPY|GetColumnNorms)",
    "MatNullSpace(Create|Destroy)",
    "VecScatter(Create|Begin|End|Destroy)",
    "MatSeqAIJSetPreallocation",
    "MatMPIAIJSetPreallocation",
    "MatMumps(SetIcntl|GetIcntl|GetInfog|GetRinfog)",
    "dmumps_c",
    "MatCreateAIJ",
    "PetscGetFlops",
    "KSP(MatSolve|GetType|Create|Destroy|SetOperators|SetOptionsPrefix|SetFromOptions|SetUp|Solve|GetPC|SetType|GetConvergedReason|GetIterationNumber|SetTolerances|GetTolerances|SetReusePreconditioner)",
    "PC(SetType|FactorSetMatSolverType|FactorGetMatSolverType|FactorSetUpMatSolverType|FactorGetMatrix|GetType)",
];
const VARS: &[&str] = &["PETSC_COMM_WORLD", "PetscOptionsPublish"];
const TYPES: &[&str] = &[
    "PetscOptionItems",
    "MatOption",
    "MatFactorSchurStatus",
    "NormType",
    "InsertMode",
    "KSPConvergedReason",
    "MatInfo",
    "MatInfoType",
    "MatAssemblyType",
    "ScatterMode",
    "MatReuse",
    "MatStructure",
    // A MUMPS factor's instance (`Mat::data` starts with MUMPS's structure): the entries of K⁻¹
    // asked of MUMPS directly (src/petsc/mumps.rs).
    "_p_Mat",
    "DMUMPS_STRUC_C",
];

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let petsc = pkg_config::Config::new()
        .atleast_version("3.18")
        .probe("PETSc")
        .expect("PETSc not found by pkg-config: install Debian's petsc-dev (see README)");
    let ompi = pkg_config::probe_library("ompi-c")
        .expect("OpenMPI not found by pkg-config: install libopenmpi-dev (see README)");
    for lib in &petsc.link_paths {
        // Find libpetsc at run time without LD_LIBRARY_PATH.
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
    // MUMPS itself (the library PETSc's factorisations use), and PETSc's private headers
    // (Debian installs them apart from the public ones) for the factor's instance.
    println!("cargo:rustc-link-lib=dmumps");
    let private = private_include(&petsc);

    let mut builder = bindgen::Builder::default()
        .header_contents(
            "wrapper.h",
            "#include <petscksp.h>\n#include <petscmat.h>\n#include <petscpc.h>\n\
             #include <petsc/private/matimpl.h>\n#include <dmumps_c.h>\n",
        )
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()))
        .layout_tests(false)
        .derive_default(true)
        .prepend_enum_name(false)
        .blocklist_item("FP_.*");
    for p in petsc.include_paths.iter().chain(ompi.include_paths.iter()) {
        builder = builder.clang_arg(format!("-I{}", p.display()));
    }
    builder = builder.clang_arg(format!("-I{}", private.display()));
    for f in FUNCTIONS {
        builder = builder.allowlist_function(f);
    }
    for v in VARS {
        builder = builder.allowlist_var(v);
    }
    for t in TYPES {
        builder = builder.allowlist_type(t);
    }
    let bindings = builder
        .generate()
        .expect("bindgen could not generate the PETSc bindings");
    let out = PathBuf::from(env::var("OUT_DIR").unwrap()).join("petsc_bindings.rs");
    bindings.write_to_file(out).expect("cannot write bindings");
}

/// The folder holding `petsc/private/matimpl.h`: beside the public headers, or where Debian
/// puts PETSc's private ones (`/usr/share/petsc/<major.minor>/include`).
fn private_include(petsc: &pkg_config::Library) -> PathBuf {
    let has = |p: &PathBuf| p.join("petsc/private/matimpl.h").is_file();
    if let Some(p) = petsc.include_paths.iter().find(|p| has(p)) {
        return p.clone();
    }
    let minor: String = petsc
        .version
        .split('.')
        .take(2)
        .collect::<Vec<_>>()
        .join(".");
    let debian = PathBuf::from(format!("/usr/share/petsc/{minor}/include"));
    assert!(
        has(&debian),
        "PETSc's private headers (petsc/private/matimpl.h) not found: install Debian's petsc-dev (see README)"
    );
    debian
}
