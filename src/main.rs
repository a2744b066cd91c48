//! `nndd`: see `nndd -help` and README.md.

use nndd::app::{self, AppError, Outcome};
use nndd::petsc::Petsc;

fn main() {
    std::panic::set_hook(Box::new(|info| {
        eprintln!("nndd: internal error: {info}");
    }));
    let Some(universe) = mpi::initialize() else {
        eprintln!("nndd: error: MPI could not be initialised");
        std::process::exit(1);
    };
    let world = universe.world();
    let rank = mpi::traits::Communicator::rank(&world);
    let size = mpi::traits::Communicator::size(&world);
    let args: Vec<String> = std::env::args().collect();
    let code = match Petsc::initialize(&args, app::HELP) {
        Err(e) => {
            eprintln!("nndd: error: {e}");
            1
        }
        Ok(petsc) => {
            let code = match app::run(world) {
                Ok(Outcome::Solved) | Ok(Outcome::Help) => 0,
                Ok(Outcome::NotConverged) => 3,
                Err(e) => report(&e, rank, size),
            };
            drop(petsc); // PetscFinalize before MPI_Finalize
            code
        }
    };
    drop(universe);
    std::process::exit(code);
}

fn report(e: &AppError, rank: i32, size: i32) -> i32 {
    if e.is_collective() {
        if rank == 0 {
            eprintln!("nndd: error: {e}");
        }
        return 1;
    }
    // A failure on one rank only: the others may wait in a collective; abort the job.
    eprintln!("nndd: error (rank {rank}): {e}");
    if size > 1 {
        use mpi::traits::Communicator;
        mpi::topology::SimpleCommunicator::world().abort(2);
    }
    2
}
