//! The factorisations made again where MUMPS's workspace fell short ([`crate::petsc::Ksp::new`]),
//! told to the user: each a warning on world rank 0's output and in the summary's `warnings`,
//! whichever rank factored it.

use crate::dd::body::Body;
use crate::parallel::layout::Layout;

/// Whose bodies were factored: the run's, the reference solution's (e_ref, (26)) or a mortar
/// run's matched meshes (its estimates' re-solves).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Factored {
    Run,
    Reference,
    Matched,
}

impl Factored {
    fn whose(self) -> &'static str {
        match self {
            Factored::Run => "",
            Factored::Reference => "the reference solution's ",
            Factored::Matched => "the matched meshes' ",
        }
    }
}

/// The warnings for the factorisations of `bodies` (this rank's, `None` for a body it does not
/// work on) made again with a larger relaxation, each said once by its group's first rank:
/// gathered on world rank 0, which says them and returns them (empty elsewhere). Collective
/// over all ranks.
pub fn relaxed_warnings(
    bodies: &[Option<Body>; 2],
    layout: &Layout,
    whose: Factored,
) -> Vec<String> {
    let mine: Vec<String> = match layout.group_rank() {
        0 => bodies
            .iter()
            .flatten()
            .flat_map(|b| warnings_of(b, whose))
            .collect(),
        _ => Vec::new(),
    };
    let all = gathered_lines(layout, &mine);
    super::say_warnings(layout.is_root(), &all);
    all
}

/// One warning per factorisation of body `b` made again ([`Body::relaxed_factorisations`]).
fn warnings_of(b: &Body, whose: Factored) -> Vec<String> {
    let alpha = b.alpha();
    let who = whose.whose();
    b.relaxed_factorisations()
        .into_iter()
        .map(|(f, more)| {
            format!(
                "{who}body {alpha}: MUMPS's factorisation fell short of workspace (INFOG(1) = {}, INFOG(2) = {}, with its estimate + {} %); factored again with -body{alpha}_mat_mumps_icntl_14 {more}",
                f.status, f.detail, f.relaxation
            )
        })
        .collect()
}

/// Every rank's `lines`, by world rank, on world rank 0 (empty elsewhere; collective).
fn gathered_lines(layout: &Layout, lines: &[String]) -> Vec<String> {
    if layout.size == 1 {
        return lines.to_vec();
    }
    let mut send = vec![Vec::new(); layout.size as usize];
    send[0] = lines.join("\n").into_bytes();
    let got = layout.exchange(true, &send);
    // (by world rank: body 1's group first)
    let texts = got.iter().map(|b| String::from_utf8_lossy(b));
    texts
        .flat_map(|t| t.lines().map(str::to_owned).collect::<Vec<_>>())
        .collect()
}
