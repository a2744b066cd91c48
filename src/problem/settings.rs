//! The problem's options (`-nndd_problem`, `-nndd_mesh` and its `-nndd_bc_…`, the built-in
//! problems' meshes and loads, the materials), read and validated into [`ProblemSettings`].

use std::collections::{BTreeMap, BTreeSet};
use std::rc::Rc;

use super::meshed::{CurveCondition, MeshSpec, MeshedError, BODY_NAMES};
use super::mortar::GapGeometry;
use super::parsed::MeshInput;
use super::parsed::ParsedFile;
use super::{ContactDiscretisation, DiscretisationChoice, ProblemKind, ProblemSettings};
use crate::fem::order::ElementOrder;
use crate::fem::wire::{Reader, Writer};
use crate::fem::Material;
use crate::fem::{geo, gmsh};
use crate::parallel::partition::{PartitionChoice, Partitioner};
use crate::parallel::root;
use crate::petsc::readers::{Bounds, SettingsError};
use crate::petsc::{self, OptionsBlock};

/// Poisson's ratio: in (−1, 0.5).
const POISSON: Bounds<f64> = Bounds {
    accepted: "in (-1, 0.5)",
    holds: |nu| nu > -1.0 && nu < 0.5,
};

const OPTS_MATERIAL: [(&str, &str); 2] = [
    ("-nndd_body1_E", "-nndd_body1_nu"),
    ("-nndd_body2_E", "-nndd_body2_nu"),
];

const OPTS_GRID: [[&str; 2]; 2] = [
    ["-nndd_body1_nx", "-nndd_body1_ny"],
    ["-nndd_body2_nx", "-nndd_body2_ny"],
];

impl ProblemSettings {
    /// Read, register (for `-help`) and validate the problem's options; what the materials
    /// allow but cost digits goes to `warnings`.
    pub fn from_options(
        o: &mut OptionsBlock,
        warnings: &mut Vec<String>,
    ) -> Result<ProblemSettings, SettingsError> {
        let (kind, mesh_file, contact) = read_kind(o)?;
        let (n, _) = o.int_in(
            "-nndd_n",
            "Mesh level n: each body is an n x n grid of split squares",
            8,
            Bounds::POSITIVE_INT,
        )?;
        let grids = read_grids(o, n)?;
        let materials = read_materials(o, warnings)?;
        let choice = o.choice(
            "-nndd_contact_discretisation",
            "With -nndd_mesh: how the contact curves meet: auto (mortar where the curves do not match, node_to_node where they do or a body is held only by contact), node_to_node (curves meshed on their own are first made to match, nodes inserted into each), mortar (segment to segment with dual multipliers, the curves as meshed: the coarser curve's nodes carry the constraints and its body takes the Dirichlet step)",
            &[
                ("auto", DiscretisationChoice::Auto),
                (
                    "node_to_node",
                    DiscretisationChoice::Given(ContactDiscretisation::NodeToNode),
                ),
                (
                    "mortar",
                    DiscretisationChoice::Given(ContactDiscretisation::Mortar),
                ),
            ],
        )?;
        let gap = o.choice(
            "-nndd_mortar_gap",
            "With the mortar discretisation: what its constraint's initial gap is measured to: curves (from each non-mortar node along its normal to the smooth curve through the mortar side's nodes: circular arcs, exact on circles; corners turning more than 20 deg kept), polygons (the dual-weighted distance between the two polygons as meshed, which differ between their nodes by the chords' heights)",
            &[("curves", GapGeometry::Curves), ("polygons", GapGeometry::Polygons)],
        )?;
        let order = o.choice(
            "-nndd_mesh_order",
            "With -nndd_mesh: the order of each body's triangles and nodes: file (the mesh file's), bands (Cuthill-McKee bands across the body, the nodes numbered as the triangles meet them: on several ranks each rank holds little more than its share of a body's fields; the patch recovery's eta_glo differs from file's by up to about 1e-3, both bounds)",
            &[("file", ElementOrder::File), ("bands", ElementOrder::Bands)],
        )?;
        let partition = o.choice(
            "-nndd_partition",
            "How each body's elements and nodes are dealt over its group of ranks: auto (blocks where the body's numbering is compact, a built-in grid's rows or a Gmsh body in -nndd_mesh_order bands; metis in a Gmsh file's own order), metis (METIS's parts of the mesh), blocks (the output's index blocks: one distribution for the assembly, the output and the estimates, so that a rank holds one share of its body's mesh, and its overlap's rings where it estimates; compact where the numbering is, not in a Gmsh file's own order)",
            &[
                ("auto", PartitionChoice::Auto),
                ("metis", PartitionChoice::Given(Partitioner::Metis)),
                ("blocks", PartitionChoice::Given(Partitioner::IndexBlocks)),
            ],
        )?;
        let input = o.choice(
            "-nndd_mesh_input",
            "With -nndd_mesh on several ranks: where the bodies are built: root (world rank 0, which reads the file, builds both, partitions them and sends every other rank its part, and its shares of the estimates, the reference solution's fine bodies alike, so that no other rank holds the file or a whole body; a mortar body with its coupling and an adaptive run's cycles alike, rank 0 remeshing; a mortar run's estimates' matched meshes and its rank's part of the maps onto them alike), every_rank (rank 0 sends every rank the parsed file, and each builds both bodies, then keeps its part)",
            &[("root", MeshInput::Root), ("every_rank", MeshInput::EveryRank)],
        )?;
        let geo_set = read_geo_set(o, kind, &mesh_file)?;
        let curves = (contact.as_str(), choice, gap);
        let mesh = match kind {
            ProblemKind::Mesh => Some(mesh_spec(o, &mesh_file, &geo_set, curves, order)?),
            _ => None,
        };
        if let Some(w) = mesh.as_ref().and_then(|m| units_warning(m, &materials)) {
            warnings.push(w);
        }
        let (u_d, _) = o.real_in(
            "-nndd_u_D",
            "Prescribed vertical displacement of the top of body 2 (m)",
            -1e-4,
            Bounds::FINITE,
        )?;
        let (f_max, _) = o.real_in(
            "-nndd_F_max",
            "Maximum of the linear load on the right edge of body 2 (Pa)",
            if kind == ProblemKind::Paper { 1e7 } else { 0.0 },
            Bounds::FINITE,
        )?;
        let partitioner = partition.resolve(mesh.as_ref().map(|m| m.order));
        Ok(ProblemSettings {
            partitioner,
            input,
            kind,
            n,
            grids,
            materials,
            mesh,
            u_d,
            f_max,
        })
    }
}

/// The problem's kind (`-nndd_mesh` sets `mesh`; another `-nndd_problem` beside it is
/// refused, as is an unknown name), the mesh file and the contact curves' names as given.
fn read_kind(o: &mut OptionsBlock) -> Result<(ProblemKind, String, String), SettingsError> {
    let (problem, problem_given) = o.string(
        "-nndd_problem",
        "Benchmark problem: paper, uniform",
        "paper",
    )?;
    let (mesh_file, mesh_given) = o.string(
        "-nndd_mesh",
        "Gmsh MSH 4.1 file of the two bodies (physical surfaces body1, body2), or their Gmsh geometry FILE.geo (meshed by the gmsh program when the run starts, parameters -nndd_geo_set); sets -nndd_problem mesh",
        "",
    )?;
    let (contact, _) = o.string(
        "-nndd_contact",
        "With -nndd_mesh: the contact curves as body 1's curve,body 2's curve (physical curve names); either may be curved, the two meshed on their own (Gamma_c is where they overlap)",
        "",
    )?;
    let unknown = |accepted: &str| SettingsError::UnknownValue {
        option: "-nndd_problem".into(),
        value: problem.clone(),
        accepted: accepted.into(),
    };
    let kind = match problem.as_str() {
        "paper" => ProblemKind::Paper,
        "uniform" => ProblemKind::Uniform,
        "mesh" if mesh_given => ProblemKind::Mesh,
        "mesh" => return Err(unknown("paper, uniform; mesh needs -nndd_mesh FILE.msh")),
        _ => return Err(unknown("paper, uniform, mesh (with -nndd_mesh)")),
    };
    if !mesh_given {
        return Ok((kind, mesh_file, contact));
    }
    if problem_given && kind != ProblemKind::Mesh {
        return Err(SettingsError::named(
            "-nndd_problem",
            format!("'{problem}' conflicts with -nndd_mesh {mesh_file}, which solves the meshed problem (beside -nndd_mesh: -nndd_problem mesh, or none)"),
        ));
    }
    Ok((ProblemKind::Mesh, mesh_file, contact))
}

/// Each body's grid (nx, ny), n × n unless given; the two grids match along Γc (the same nx).
fn read_grids(o: &mut OptionsBlock, n: usize) -> Result<[(usize, usize); 2], SettingsError> {
    let mut grids = [(n, n); 2];
    for (b, grid) in grids.iter_mut().enumerate() {
        let [nx, ny] = OPTS_GRID[b].map(|opt| {
            let axis = &opt[opt.len() - 1..];
            let help = format!("Body {} cells in {axis} (default n)", b + 1);
            (opt, help)
        });
        grid.0 = o.int_in(nx.0, &nx.1, n, Bounds::POSITIVE_INT)?.0;
        grid.1 = o.int_in(ny.0, &ny.1, n, Bounds::POSITIVE_INT)?.0;
    }
    if grids[0].0 != grids[1].0 {
        return Err(SettingsError::out_of_range(
            "-nndd_body2_nx",
            "equal to -nndd_body1_nx (matching nodes on the contact interface)",
            format!("{} vs {}", grids[1].0, grids[0].0),
        ));
    }
    Ok(grids)
}

/// Both bodies' materials: `-nndd_E`, `-nndd_nu`, overridden per body by
/// `-nndd_body<α>_{E,nu}`; refused where the solve would lose its digits.
fn read_materials(
    o: &mut OptionsBlock,
    warnings: &mut Vec<String>,
) -> Result<[Material; 2], SettingsError> {
    let (young, _) = o.real_in(
        "-nndd_E",
        "Young's modulus E of both bodies (Pa)",
        210e9,
        Bounds::POSITIVE,
    )?;
    let (poisson, _) = o.real_in(
        "-nndd_nu",
        "Poisson's ratio of both bodies, in (-1, 0.5)",
        0.27,
        POISSON,
    )?;
    let mut materials = [Material { young, poisson }; 2];
    let (mut e_given, mut nu_given) = ([false; 2], [false; 2]);
    for (b, m) in materials.iter_mut().enumerate() {
        let (e_opt, nu_opt) = OPTS_MATERIAL[b];
        let help = format!("Young's modulus of body {} (Pa; default -nndd_E)", b + 1);
        (m.young, e_given[b]) = o.real_in(e_opt, &help, young, Bounds::POSITIVE)?;
        let help = format!(
            "Poisson's ratio of body {}, in (-1, 0.5) (default -nndd_nu)",
            b + 1
        );
        (m.poisson, nu_given[b]) = o.real_in(nu_opt, &help, poisson, POISSON)?;
    }
    warnings.extend(check_materials(&materials, e_given, nu_given)?);
    Ok(materials)
}

/// The meshed problem of `-nndd_mesh`: the file, the contact curves, and for every physical
/// curve of the mesh its `-nndd_bc_NAME_{ux,uy,traction,traction_end}` options.
/// `-nndd_geo_set`: the parameters of a `-nndd_mesh FILE.geo` (refused with anything else).
fn read_geo_set(
    o: &mut OptionsBlock,
    kind: ProblemKind,
    mesh_file: &str,
) -> Result<Vec<(String, f64)>, SettingsError> {
    const OPT: &str = "-nndd_geo_set";
    let (text, given) = o.string(
        OPT,
        "With -nndd_mesh FILE.geo (meshed by the gmsh program when the run starts, on rank 0): its parameters as NAME=VALUE,... (Gmsh's -setnumber NAME VALUE), e.g. level=2,ratio=1.5",
        "",
    )?;
    if given && !(kind == ProblemKind::Mesh && geo::is_geo(std::path::Path::new(mesh_file))) {
        return Err(SettingsError::named(
            OPT,
            "sets parameters of a Gmsh geometry given as -nndd_mesh FILE.geo, which is meshed when the run starts; a .msh file is meshed already",
        ));
    }
    geo::parse_parameters(&text).map_err(|e| SettingsError::named(OPT, e))
}

/// The Gmsh problem of the mesh `file` (with the `.geo` parameters `geo_set`): its contact
/// curves `(contact, choice, gap)` as `-nndd_contact`, `-nndd_contact_discretisation` and
/// `-nndd_mortar_gap` say, its bodies in the `order` of `-nndd_mesh_order`.
fn mesh_spec(
    o: &mut OptionsBlock,
    file: &str,
    geo_set: &[(String, f64)],
    (contact, choice, gap): (&str, DiscretisationChoice, GapGeometry),
    order: ElementOrder,
) -> Result<MeshSpec, SettingsError> {
    let named = SettingsError::named;
    // (the mesh on world rank 0, the names on every rank: the options are checked on them)
    let (gmsh, names) = read_on_root(file, geo_set).map_err(|e| named("-nndd_mesh", e))?;
    let group_names = |dim: i32| gmsh::group_names(&names, dim);
    // The bodies first: without them nothing else the options name can be found.
    let missing: Vec<&str> = BODY_NAMES
        .into_iter()
        .filter(|b| gmsh::tag_of(&names, 2, b).is_none())
        .collect();
    if !missing.is_empty() {
        return Err(named(
            "-nndd_mesh",
            format!(
                "{file} has no physical surface {} (its physical surfaces: {}; physical curves: {}); name the two bodies and the curves the options refer to in the .geo file: Physical Surface(\"body1\") = {{…}}; Physical Surface(\"body2\") = {{…}}; Physical Curve(\"NAME\") = {{…}};",
                missing
                    .iter()
                    .map(|b| format!("'{b}'"))
                    .collect::<Vec<_>>()
                    .join(" or "),
                group_names(2),
                group_names(1)
            ),
        ));
    }
    let curves: Vec<String> = names
        .iter()
        .filter(|((d, _), _)| *d == 1)
        .map(|(_, n)| n.clone())
        .collect();
    let pair: Vec<&str> = contact.split(',').map(str::trim).collect();
    if pair.len() != 2 || pair.iter().any(|c| c.is_empty()) {
        return Err(named(
            "-nndd_contact",
            format!(
                "give body 1's and body 2's contact curves as NAME1,NAME2 (got '{contact}'; physical curves: {})",
                group_names(1)
            ),
        ));
    }
    let vector = |option: &str, text: &str| -> Result<[f64; 2], SettingsError> {
        let v: Vec<f64> = text
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| named(option, format!("expects two numbers tx,ty (got '{text}')")))?;
        match v[..] {
            [a, b] if a.is_finite() && b.is_finite() => Ok([a, b]),
            _ => Err(named(
                option,
                format!("expects two finite numbers tx,ty (got '{text}')"),
            )),
        }
    };
    let mut conditions = Vec::new();
    let mut known = BTreeSet::new();
    for c in &curves {
        let mut cond = CurveCondition {
            curve: c.clone(),
            ..Default::default()
        };
        for (k, comp) in ["ux", "uy"].iter().enumerate() {
            let opt = format!("-nndd_bc_{c}_{comp}");
            let (v, set) = o.real(
                &opt,
                &format!("Prescribed {comp} on the curve {c} (m)"),
                0.0,
            )?;
            if set {
                if !v.is_finite() {
                    return Err(named(&opt, format!("must be a finite number (got {v})")));
                }
                cond.u[k] = Some(v);
            }
            known.insert(opt);
        }
        let opt = format!("-nndd_bc_{c}_traction");
        let opt_end = format!("-nndd_bc_{c}_traction_end");
        let (t0, set0) = o.string(
            &opt,
            &format!("Traction tx,ty on the curve {c} (Pa), at its first point"),
            "",
        )?;
        let (t1, set1) = o.string(
            &opt_end,
            &format!("Traction tx,ty at the last point of {c} (Pa; linear in between; default: as -nndd_bc_{c}_traction)"),
            "",
        )?;
        if set1 && !set0 {
            return Err(named(
                &opt_end,
                format!("needs {opt} (the traction at the curve's first point)"),
            ));
        }
        if set0 {
            let a = vector(&opt, &t0)?;
            let b = if set1 { vector(&opt_end, &t1)? } else { a };
            // A roller and a load on one curve: the traction may act only along the free
            // component (its component along a prescribed one would go to the reaction).
            for (k, comp) in ["x", "y"].iter().enumerate() {
                if cond.u[k].is_some() && (a[k] != 0.0 || b[k] != 0.0) {
                    return Err(named(
                        &opt,
                        format!("has a nonzero t{comp} on the curve {c}, where -nndd_bc_{c}_u{comp} prescribes the displacement (a traction acts only along a free component: t{comp} = 0)"),
                    ));
                }
            }
            cond.traction = Some([a, b]);
        }
        known.insert(opt);
        known.insert(opt_end);
        if cond.traction.is_some() || cond.u.iter().any(Option::is_some) {
            conditions.push(cond);
        }
    }
    // A -nndd_bc_ option that names no curve of the mesh is a typo: refuse it.
    for name in petsc::option_names()? {
        if name.starts_with("-nndd_bc_") && !known.contains(&name) {
            return Err(named(
                &name,
                format!(
                    "names no physical curve of {file} or no condition (accepted: -nndd_bc_NAME_ux, _uy, _traction, _traction_end with NAME in: {})",
                    group_names(1)
                ),
            ));
        }
    }
    let contact = [pair[0].to_string(), pair[1].to_string()];
    let (parsed, discretisation, matched) =
        resolve_on_root(file, gmsh, &contact, choice).map_err(|e| named("-nndd_mesh", e))?;
    Ok(MeshSpec {
        gmsh: parsed,
        conditions,
        contact,
        discretisation,
        choice,
        gap,
        geo_set: geo_set.to_vec(),
        nested: None,
        order,
        matched: Rc::new(matched),
    })
}

/// The contact discretisation `choice` resolved on the mesh `gmsh` (`auto`: node to node where
/// the curves match without an inserted node and none closes, else mortar), and the mesh it
/// works on (the curves made to match, node to node).
fn resolve(
    gmsh: gmsh::GmshMesh,
    contact: &[String; 2],
    choice: DiscretisationChoice,
) -> (
    gmsh::GmshMesh,
    ContactDiscretisation,
    super::matched::Matched,
) {
    let (conformed, matched) = match choice {
        DiscretisationChoice::Given(ContactDiscretisation::Mortar) => {
            (gmsh.clone(), Default::default())
        }
        _ => super::conform::conform(&gmsh, contact),
    };
    // (auto: the curves match where making them match inserted no node; a node within SNAP
    // of its partner on a straight part is moved onto it, as node to node always did)
    let matching = matched.inserted == [0, 0];
    let discretisation = match choice {
        DiscretisationChoice::Given(d) => d,
        DiscretisationChoice::Auto
            if matching && !contact.iter().any(|c| super::curves::is_closed(&gmsh, c)) =>
        {
            ContactDiscretisation::NodeToNode
        }
        DiscretisationChoice::Auto => ContactDiscretisation::Mortar,
    };
    match discretisation {
        ContactDiscretisation::NodeToNode => (conformed, discretisation, matched),
        ContactDiscretisation::Mortar => (gmsh, discretisation, Default::default()),
    }
}

impl MeshSpec {
    /// The same problem on a new mesh `gmsh` of its geometry (an adaptive run's next cycle),
    /// given on world rank 0 and on the other ranks that hold it (`None` on those that do
    /// not: they are told the file's facts, [`resolve_on_root`]): the contact curves resolved
    /// as [`mesh_spec`] does. Collective; an error on every rank where rank 0 has no mesh.
    pub fn remeshed(&self, gmsh: Option<gmsh::GmshMesh>) -> Result<MeshSpec, String> {
        let (gmsh, discretisation, matched) =
            resolve_on_root(&self.gmsh.path, gmsh, &self.contact, self.choice)?;
        Ok(MeshSpec {
            gmsh,
            discretisation,
            matched: Rc::new(matched),
            ..self.clone()
        })
    }

    /// The same problem node to node (`auto`'s choice where mortar is not available): the
    /// user's curves made to match ([`super::conform`]) on world rank 0, the others told what
    /// it made (where they do not hold the file: `-nndd_mesh_input root`). Collective.
    pub fn node_to_node(&self) -> Result<MeshSpec, MeshedError> {
        if self.discretisation == ContactDiscretisation::NodeToNode {
            return Ok(self.clone());
        }
        let mesh = self.gmsh.mesh().ok().cloned();
        let given = DiscretisationChoice::Given(ContactDiscretisation::NodeToNode);
        let (gmsh, discretisation, matched) =
            resolve_on_root(&self.gmsh.path, mesh, &self.contact, given)
                .map_err(|e| super::curves::opt_err("-nndd_mesh", e))?;
        Ok(MeshSpec {
            gmsh,
            discretisation,
            matched: Rc::new(matched),
            ..self.clone()
        })
    }
}

/// The options that define the built-in problems' meshes and loads (not a Gmsh problem's).
pub const BUILTIN_ONLY: [&str; 7] = [
    "-nndd_n",
    "-nndd_body1_nx",
    "-nndd_body1_ny",
    "-nndd_body2_nx",
    "-nndd_body2_ny",
    "-nndd_u_D",
    "-nndd_F_max",
];

/// Whether the option `name`, given, applies to a problem of `kind`: `-nndd_bc_…` only to a
/// Gmsh problem (checked against its curves as they are read), the built-in problems' mesh
/// and load options not to one, `-nndd_contact` only to one.
pub fn option_applies(kind: ProblemKind, name: &str) -> Result<(), SettingsError> {
    let mesh = kind == ProblemKind::Mesh;
    if name.starts_with("-nndd_bc_") && !mesh {
        return Err(SettingsError::named(
            name,
            "sets a boundary condition of a Gmsh problem (-nndd_mesh); the built-in problems have theirs (docs/benchmarks.md)",
        ));
    }
    if mesh && BUILTIN_ONLY.contains(&name) {
        return Err(SettingsError::named(
            name,
            "sets the built-in problems' mesh or load and does not apply to a Gmsh problem (-nndd_mesh): its mesh sizes are the .geo file's, its conditions -nndd_bc_NAME_ux, _uy, _traction",
        ));
    }
    if !mesh && ["-nndd_contact_discretisation", "-nndd_mortar_gap"].contains(&name) {
        return Err(SettingsError::named(
            name,
            "sets how the contact curves of a Gmsh problem (-nndd_mesh) meet; the built-in problems' meshes match node to node",
        ));
    }
    if !mesh && name == "-nndd_mesh_order" {
        return Err(SettingsError::named(
            name,
            "orders the bodies of a Gmsh problem (-nndd_mesh); the built-in problems' grids are numbered row by row",
        ));
    }
    if !mesh && name == "-nndd_mesh_input" {
        return Err(SettingsError::named(
            name,
            "says where a Gmsh problem's bodies (-nndd_mesh) are built; a built-in body's mesh is its grid's formula, built on no rank",
        ));
    }
    if !mesh && name == "-nndd_contact" {
        return Err(SettingsError::named(
            name,
            "names the contact curves of a Gmsh problem and needs -nndd_mesh FILE.msh",
        ));
    }
    Ok(())
}

/// A mesh at least this large (m, its bounding box's larger side) with moduli in the
/// pascals' range ([`PASCAL_MODULI`]) is probably drawn in millimetres.
pub const MILLIMETRE_MESH: f64 = 10.0;
/// Young's moduli above this (Pa) are a metal's or a polymer's in pascals, not in MPa.
pub const PASCAL_MODULI: f64 = 1e8;

/// The warning of a mesh whose size suggests millimetres while the moduli are in pascals
/// (nndd reads coordinates in metres: a part drawn in mm is 1000 times too large, and a
/// prescribed displacement strains it 1000 times too little).
fn units_warning(mesh: &MeshSpec, materials: &[Material; 2]) -> Option<String> {
    let [lo, hi] = mesh.gmsh.bbox;
    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let e = materials[0].young.max(materials[1].young);
    (size >= MILLIMETRE_MESH && e > PASCAL_MODULI).then(|| {
        format!(
            "-nndd_mesh {}: the mesh spans {size} m as nndd reads it (coordinates in metres) with moduli in pascals (E up to {e:.3e} Pa); if it is drawn in millimetres, scale it (Gmsh: Mesh.ScalingFactor = 0.001) or give moduli and tractions in MPa and displacements in mm",
            mesh.gmsh.path
        )
    })
}

/// The largest λ/μ = 2ν/(1 − 2ν) (plane strain) accepted: ν ≤ 0.499999995. Nearly
/// incompressible P1 triangles lock, and the stiffness matrix carries λ/μ as a condition
/// factor on top of the mesh's: on `paper` n = 16 the NNDD equals the monolithic solve to
/// 1e−8 at ν = 0.49999999 (λ/μ = 5e7) but is 1.6 % off at ν = 0.4999999999 (5e9).
pub const MAX_LAME_RATIO: f64 = 1e8;
/// λ/μ above which a warning says so (ν > 0.4995): the locking of P1 triangles makes the
/// displacements visibly too small.
pub const WARN_LAME_RATIO: f64 = 1e3;
/// The largest ratio of the two bodies' Young's moduli accepted. A stiff body that moves
/// as a whole deforms by about 1/ratio of its displacement, and its forces carry the round-off
/// of that displacement amplified by the ratio. On `paper` n = 16 with body 2 the stiffer, the
/// NNDD balances the forces to 1e−9 and equals the monolithic energy to 1e−9 up to 1e6, with
/// the Dirichlet step on either body (`jobs/stiffness --limits`); at 1e8 the forces balance to
/// no better than 5e−8 and the monolithic energy leaves its trend by 1e−6.
pub const MAX_STIFFNESS_RATIO: f64 = 1e6;

/// Refuse materials whose solve would lose its digits; return the warnings for those that
/// cost some. `e_given`, `nu_given`: whether `-nndd_body<α>_E`, `-nndd_body<α>_nu` were
/// given (else a message names `-nndd_E`, `-nndd_nu`).
fn check_materials(
    materials: &[Material; 2],
    e_given: [bool; 2],
    nu_given: [bool; 2],
) -> Result<Vec<String>, SettingsError> {
    let mut warnings = Vec::new();
    for (b, m) in materials.iter().enumerate() {
        let nu_opt = if nu_given[b] {
            OPTS_MATERIAL[b].1
        } else {
            "-nndd_nu"
        };
        let lame = 2.0 * m.poisson / (1.0 - 2.0 * m.poisson);
        if lame > MAX_LAME_RATIO {
            return Err(SettingsError::named(
                &format!("{nu_opt} {}", m.poisson),
                format!(
                    "body {} is too nearly incompressible for a displacement formulation (λ/μ = {lame:.1e}; at most {MAX_LAME_RATIO:.0e}, ν ≤ 0.499999995, keeps 8 of the 16 digits)",
                    b + 1
                ),
            ));
        }
        if lame > WARN_LAME_RATIO {
            warnings.push(format!(
                "{nu_opt} {}: body {} is nearly incompressible (λ/μ = {lame:.1e}): P1 triangles lock, so its displacements are too small, and the solve loses about {:.0} digits",
                m.poisson,
                b + 1,
                lame.log10()
            ));
        }
    }
    let (e1, e2) = (materials[0].young, materials[1].young);
    let ratio = e1.max(e2) / e1.min(e2);
    if ratio > MAX_STIFFNESS_RATIO {
        let b = if e_given[0] { 0 } else { 1 };
        return Err(SettingsError::named(
            &format!("{} {:e}", OPTS_MATERIAL[b].0, materials[b].young),
            format!(
                "the bodies' stiffness ratio {ratio:.1e} is beyond {MAX_STIFFNESS_RATIO:.0e}: double precision cannot resolve the stiffer body's deformation against its displacement (its forces carry round-off amplified by the ratio); bring the moduli closer, or model the stiffer body as rigid (a displacement condition on the other body's contact curve)"
            ),
        ));
    }
    Ok(warnings)
}

/// The mesh file, read and parsed on world rank 0 (a `.geo` file meshed there first by gmsh
/// with `geo_set`, [`geo::mesh`]), and its physical names, sent to the other ranks: the options
/// are checked against the names on every rank, the rest on rank 0 ([`resolve_on_root`]).
/// Collective; an error on rank 0 reaches every rank (the others' message says so).
#[allow(clippy::type_complexity)]
fn read_on_root(
    file: &str,
    geo_set: &[(String, f64)],
) -> Result<(Option<gmsh::GmshMesh>, BTreeMap<(i32, i32), String>), String> {
    let path = std::path::Path::new(file);
    let mut mesh = None;
    let bytes = root::bytes_from_root(file, || {
        let m = match geo::is_geo(path) {
            true => geo::mesh(path, geo_set),
            false => gmsh::read(path),
        }
        .map_err(|e| e.to_string())?;
        let mut w = Writer::default();
        gmsh::write_names(&mut w, &m.names);
        mesh = Some(m);
        Ok(w.0)
    })?;
    let names = match &mesh {
        Some(m) => m.names.clone(),
        None => gmsh::read_names(&mut Reader::new(&bytes))
            .ok_or_else(|| format!("{file}: the names sent by world rank 0 are damaged"))?,
    };
    Ok((mesh, names))
}

/// The contact curves `contact` resolved as `choice` says on world rank 0, which holds the
/// `mesh` ([`resolve`]), and the file it gives there; the others learn what it found and the
/// file's facts ([`ParsedFile::on_root`]). Collective.
fn resolve_on_root(
    file: &str,
    mesh: Option<gmsh::GmshMesh>,
    contact: &[String; 2],
    choice: DiscretisationChoice,
) -> Result<(ParsedFile, ContactDiscretisation, super::matched::Matched), String> {
    let resolved = mesh.map(|m| {
        let (m, discretisation, matched) = resolve(m, contact, choice);
        (ParsedFile::new(m), discretisation, matched)
    });
    let facts = resolved.as_ref().map(|(parsed, discretisation, matched)| {
        let mut w = Writer::default();
        w.u8(match discretisation {
            ContactDiscretisation::NodeToNode => 0,
            ContactDiscretisation::Mortar => 1,
        });
        matched.write(&mut w);
        parsed.write_facts(&mut w);
        w.0
    });
    let bytes = root::bytes_from_root(file, move || {
        facts.ok_or_else(|| format!("{file}: world rank 0 holds no mesh"))
    })?;
    if let Some(resolved) = resolved {
        return Ok(resolved);
    }
    let damaged = || format!("{file}: the facts sent by world rank 0 are damaged");
    let mut r = Reader::new(&bytes);
    let discretisation = match r.u8().ok_or_else(damaged)? {
        0 => ContactDiscretisation::NodeToNode,
        _ => ContactDiscretisation::Mortar,
    };
    let matched = super::matched::Matched::read(&mut r).ok_or_else(damaged)?;
    let facts = ParsedFile::read_facts(&mut r).filter(|_| r.is_done());
    Ok((facts.ok_or_else(damaged)?, discretisation, matched))
}
