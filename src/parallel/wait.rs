//! Waiting for other ranks without taking their core. MPI's blocking calls wait by polling,
//! so a rank that reaches a collective early keeps a core busy while the ranks it waits for
//! (a parse on rank 0, the other body's factorisation) may need it: where more ranks than
//! cores run, every waiting rank slows the working ones. A wait through [`politely`] polls a
//! non-blocking request for a moment, then sleeps between polls.

use std::time::{Duration, Instant};

use mpi::request::{Request, Scope};

/// How long a wait polls before it starts to sleep: the waits of the NNDD's interface
/// exchanges end within it when the ranks are in step.
const POLL: Duration = Duration::from_micros(100);

/// The longest sleep between two polls.
const NAP: Duration = Duration::from_millis(1);

/// Wait for `req` to complete: poll it for [`POLL`], then sleep between polls, the sleeps
/// growing to [`NAP`] (a wait of t costs at most about t/8 + 1 ms more than a blocking one).
pub fn politely<'a, D: ?Sized, S: Scope<'a>>(mut req: Request<'a, D, S>) {
    let t0 = Instant::now();
    loop {
        match req.test() {
            Ok(_) => return,
            Err(r) => req = r,
        }
        let waited = t0.elapsed();
        if waited > POLL {
            std::thread::sleep((waited / 8).min(NAP));
        }
    }
}
