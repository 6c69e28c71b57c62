//! `lgc mesh`: a closed, 2-manifold triangle mesh of the surface, or of
//! each object of a scene, every vertex within a proved distance of it,
//! written as STL, OBJ, PLY, glTF binary or 3MF by the output's extension.

use super::args::{
    aabb_from, fmt3, json_number, num, parse_count, parse_numbers, progress_bar, thread_pool,
    Failure, Outcome, SourceArgs,
};
use anyhow::Context as _;
use clap::Args;
use lgc::mesh::scene::mesh_scene_with_progress;
use lgc::mesh::write::{Part, PendingMesh};
use lgc::mesh::{mesh_with_progress, Doubt, MeshOptions, Meshed, Progress, Witness};
use lgc::render::shade::srgb_to_linear;
use lgc::types::rounding::up_bound;
use std::path::PathBuf;

/// Cells per axis of the default lattice: 2^7.
const DEFAULT_DEPTH: u32 = 7;

/// The most cells `--max-cells` may allow. A cell that f crosses costs
/// about 1.2 KB through the build (the gyroid cut by a ball: 453 MB for
/// 379,319 cells), so this keeps a mesh under about 5 GB.
const MAX_CELLS: u64 = 1 << 22;

/// Options of `lgc mesh`.
#[derive(Args, Debug)]
pub struct MeshArgs {
    #[command(flatten)]
    source: SourceArgs,
    /// The mesh file: .stl (binary), .obj, .ply (binary), .glb or .3mf.
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    /// The box X0,Y0,Z0,X1,Y1,Z1 to mesh, -2,-2,-2,2,2,2 if not given; the
    /// solid f < 0 is cut by it. A scene's objects are meshed in their own
    /// boxes.
    #[arg(long = "box", value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true, value_parser = parse_numbers::<6>)]
    region: Option<[f64; 6]>,
    /// Cells per axis: 2^N (cells f cannot cross are never visited).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_DEPTH, value_parser = parse_mesh_depth)]
    depth: u32,
    /// In a certified cell, the mesh and the surface are within this of each
    /// other, both ways (default: a quarter of a cell's side); every vertex
    /// lies within a sixteenth of it of a proved root of f.
    #[arg(long, value_name = "EPS", allow_hyphen_values = true)]
    tolerance: Option<f64>,
    /// The most cells kept at one level (at most 4194304): a level that
    /// would hold more stops at the one before, which bounds time and memory
    /// (about 1.2 KB a cell).
    #[arg(long, value_name = "N", default_value_t = 1 << 20, value_parser = parse_count)]
    max_cells: u64,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Print the summary as one JSON object, with every uncertified cell.
    #[arg(long)]
    json: bool,
}

/// Parses `--depth` of a mesh: up to the lattice's deepest level.
fn parse_mesh_depth(text: &str) -> Result<u32, String> {
    let max = lgc::mesh::lattice::MAX_DEPTH;
    match text.trim().parse::<u32>() {
        Ok(d) if d <= max => Ok(d),
        _ => Err(format!(
            "use a whole number from 0 to {max} (2^N cells per axis)"
        )),
    }
}

/// The box meshed when `--box` is not given.
const DEFAULT_BOX: [f64; 6] = [-2.0, -2.0, -2.0, 2.0, 2.0, 2.0];

/// Meshes the surface, or each object of a scene, and writes the file.
pub fn run(args: &MeshArgs) -> Outcome {
    if args.max_cells > MAX_CELLS {
        return Err(anyhow::anyhow!(
            "--max-cells {}: use at most {MAX_CELLS} (about 1.2 KB of memory a cell)",
            args.max_cells
        )
        .into());
    }
    let source = args.source.read()?;
    let input = if !source.is_vm() && lgc::scene::is_scene(&source.text) {
        if args.region.is_some() {
            return Err(anyhow::anyhow!(
                "--box: {} is a scene, and each of its objects is meshed in its own box",
                source.origin
            )
            .into());
        }
        Input::Scene(lgc::scene::parse_scene(&source.text).map_err(|e| source.located(e))?)
    } else {
        Input::Formula(source.formula()?)
    };
    let b = aabb_from(args.region.unwrap_or(DEFAULT_BOX))?;
    let pool = thread_pool(args.threads)?;
    let tolerance = match args.tolerance {
        Some(t) if t > 0.0 && t.is_finite() => Some(t),
        Some(t) => {
            return Err(anyhow::anyhow!("--tolerance {}: use a positive number", num(t)).into())
        }
        None => None,
    };
    let options = MeshOptions {
        depth: args.depth,
        tolerance,
        max_cells: usize::try_from(args.max_cells).unwrap_or(usize::MAX),
    };
    // The file is reserved before any work, so a bad path fails at once.
    let pending = PendingMesh::create(&args.output).map_err(anyhow::Error::new)?;
    let mut objects = match &input {
        Input::Scene(scene) => mesh_scene(scene, &source, &options, &pool)?,
        Input::Formula(formula) => {
            let meshed = with_bar(
                |_| String::new(),
                |report| {
                    pool.install(|| {
                        mesh_with_progress(formula, &b, &options, &|stage| report(0, stage))
                    })
                },
            )?;
            vec![Object {
                name: "surface".into(),
                bounds: b,
                color: None,
                meshed,
            }]
        }
    };
    let parts: Vec<Part> = objects
        .iter()
        .map(|o| Part {
            name: &o.name,
            mesh: &o.meshed.mesh,
            color: o.color,
        })
        .collect();
    let single = pending.format().single_precision();
    pending
        .finish(&parts)
        .with_context(|| "the mesh was not written")?;
    // The file's vertices moved by their rounding, if the format stores f32,
    // and every distance the summary gives grows by as much.
    let reaches: Vec<f64> = objects
        .iter_mut()
        .map(|o| {
            let moved = rounding(&o.meshed.mesh, single);
            if moved > 0.0 {
                let c = &mut o.meshed.certificate;
                c.moved(1.0, moved, c.tolerance);
            }
            let radius = o.meshed.mesh.radii.iter().copied().fold(0.0, f64::max);
            up_bound(radius + moved)
        })
        .collect();
    let scene = matches!(input, Input::Scene(_));
    summarise(args, scene, &objects, &reaches);
    notes(&objects, args.depth, scene);
    Ok(0)
}

/// Prints the summary, as text or JSON: a formula's mesh, or each object of
/// a scene after the totals.
fn summarise(args: &MeshArgs, scene: bool, objects: &[Object], reaches: &[f64]) {
    match (scene, args.json) {
        (false, true) => {
            let mut summary = json_summary(&objects[0].meshed, reaches[0]);
            summary["file"] = args.output.display().to_string().into();
            println!("{summary}");
        }
        (false, false) => {
            let m = &objects[0].meshed;
            println!(
                "wrote {}: {}; closed, 2-manifold, wound with f increasing outward",
                args.output.display(),
                counts(m)
            );
            details(m, &objects[0].bounds, reaches[0], "");
        }
        (true, true) => {
            let list: Vec<serde_json::Value> = objects
                .iter()
                .zip(reaches)
                .map(|(o, &r)| {
                    let mut summary = json_summary(&o.meshed, r);
                    summary["name"] = o.name.clone().into();
                    summary
                })
                .collect();
            println!(
                "{}",
                serde_json::json!({
                    "file": args.output.display().to_string(),
                    "objects": list,
                })
            );
        }
        (true, false) => {
            let total =
                |f: fn(&Meshed) -> usize| objects.iter().map(|o| f(&o.meshed)).sum::<usize>();
            println!(
                "wrote {}: {} objects, {} vertices, {} triangles; each closed, 2-manifold, wound with f increasing outward",
                args.output.display(),
                objects.len(),
                total(|m| m.mesh.positions.len()),
                total(|m| m.mesh.triangles.len()),
            );
            for (o, &r) in objects.iter().zip(reaches) {
                println!("{}: {}", o.name, counts(&o.meshed));
                details(&o.meshed, &o.bounds, r, "  ");
            }
        }
    }
}

/// Meshes each object of a scene, named by its block and where it starts,
/// in the scene's colour.
fn mesh_scene(
    scene: &lgc::scene::Scene,
    source: &super::args::Source,
    options: &MeshOptions,
    pool: &rayon::ThreadPool,
) -> Result<Vec<Object>, Failure> {
    let n = scene.objects.len();
    let meshes = with_bar(
        |i| format!("object {} of {n}: ", i + 1),
        |report| pool.install(|| mesh_scene_with_progress(scene, options, report)),
    )?;
    let objects = scene
        .objects
        .iter()
        .zip(meshes)
        .map(|(o, meshed)| {
            let (line, column) = lgc::lang::line_column(&source.text, o.span.start);
            Object {
                name: format!("{} at {line}:{column}", o.kind),
                bounds: o.bounds,
                color: Some(o.material.color.map(srgb_to_linear).as_vec3().to_array()),
                meshed,
            }
        })
        .collect();
    Ok(objects)
}

/// What is meshed: a formula, or each object of a scene.
enum Input {
    Formula(lgc::Formula),
    Scene(lgc::scene::Scene),
}

/// One meshed object of the output, with what its summary needs.
struct Object {
    /// Its name in the file and the summary.
    name: String,
    /// The box it was meshed in, in scene coordinates.
    bounds: lgc::Aabb,
    /// Its base colour, linear RGB, for formats that keep one.
    color: Option<[f32; 3]>,
    /// Its mesh.
    meshed: Meshed,
}

/// Runs `work` with a progress bar (shown on a terminal only) that names
/// each stage, vertices placed then cells certified, after `what` of the
/// object at it.
fn with_bar<T>(
    what: impl Fn(usize) -> String + Sync,
    work: impl FnOnce(&(dyn Fn(usize, Progress) + Sync)) -> Result<T, lgc::mesh::MeshError>,
) -> Result<T, Failure> {
    let bar = progress_bar(0, "{msg}");
    let report = |i: usize, p: Progress| match p {
        Progress::Cells => {
            bar.set_message(format!("{}vertices", what(i)));
            bar.set_position(0);
        }
        Progress::Vertices(n) => bar.set_length(n),
        Progress::Certify(n) => {
            bar.set_message(format!("{}cells certified", what(i)));
            bar.set_position(0);
            bar.set_length(n);
        }
        Progress::Placed(n) | Progress::Certified(n) => bar.inc(n),
        Progress::Check => {}
    };
    let result = work(&report);
    bar.finish_and_clear();
    // On an error, the caller's pending file is dropped, which removes it.
    result.map_err(|e| Failure::Other(anyhow::Error::new(e)))
}

/// Prints which cells the mesh is isotopic to the surface in, and where the
/// others are.
fn certification(m: &Meshed, indent: &str) {
    let c = &m.certificate;
    let reach = format!(
        "each within {} of the other (the mesh within {} of the surface, the surface within {} of the mesh; tolerance {})",
        num(c.hausdorff),
        num(c.mesh_to_surface),
        num(c.surface_to_mesh),
        num(c.tolerance)
    );
    if c.is_complete() {
        println!(
            "{indent}certified: all {} cells: the mesh is isotopic to the surface in the box and {reach}",
            c.certified
        );
        return;
    }
    if c.certified > 0 {
        println!(
            "{indent}certified: {} of {} cells: in each, the mesh is isotopic to the surface and {reach}",
            c.certified, m.cells
        );
    } else {
        println!("{indent}certified: none of {} cells", m.cells);
    }
    // Each doubt with where its first cell is.
    let reasons: Vec<String> = Doubt::ALL
        .iter()
        .filter_map(|&d| {
            let first = c.uncertified.iter().find(|u| u.doubt == d)?;
            Some(format!(
                "{} where {}, the first centred at {}",
                c.count(d),
                d.describe(),
                fmt3(0.5 * (first.cell.lo + first.cell.hi))
            ))
        })
        .collect();
    println!(
        "{indent}uncertified: {} cells: {}",
        c.uncertified.len(),
        reasons.join("; ")
    );
}

/// A mesh's size and shape in one phrase.
fn counts(m: &Meshed) -> String {
    let t = &m.topology;
    format!(
        "{} vertices, {} triangles, {} component{}, Euler characteristic {}",
        m.mesh.positions.len(),
        m.mesh.triangles.len(),
        t.components,
        if t.components == 1 { "" } else { "s" },
        t.euler
    )
}

/// Prints the cells, the vertices' witnesses and the certificate of a mesh
/// made in the box `b`.
fn details(m: &Meshed, b: &lgc::Aabb, reach: f64, indent: &str) {
    let mesh = &m.mesh;
    let width = (b.hi - b.lo) / (1u64 << m.level) as f64;
    println!(
        "{indent}cells: {} of {}^3 at depth {} (each {}) that f may cross, {} where f may jump or lack a value",
        m.cells,
        1u64 << m.level,
        m.level,
        fmt3(width),
        m.discontinuous_cells
    );
    let count = |w: Witness| mesh.count(w);
    println!(
        "{indent}vertices: {} within {} of a proved root, {} of a point where f's enclosure holds 0; tolerance {}",
        count(Witness::Root),
        num(reach),
        count(Witness::Tolerance),
        num(m.certificate.tolerance)
    );
    certification(m, indent);
    let sharp = &m.sharpened;
    if sharp.cells > 0 {
        println!(
            "{indent}creases: {} uncertified cells fanned from a point on a crease, with a vertex at {} places where a crease crosses a lattice face",
            sharp.cells, sharp.face_vertices
        );
    }
}

/// How far rounding to f32 moved a vertex at most, if the format stores
/// f32 (else 0).
fn rounding(mesh: &lgc::mesh::Mesh, single: bool) -> f64 {
    if !single {
        return 0.0;
    }
    let moved = |p: &glam::DVec3| (p.as_vec3().as_dvec3() - *p).length();
    mesh.positions.iter().map(moved).fold(0.0, f64::max)
}

/// The summary as JSON: the text summary's figures, and every uncertified
/// cell with its reason.
fn json_summary(m: &Meshed, reach: f64) -> serde_json::Value {
    let mesh = &m.mesh;
    let c = &m.certificate;
    let doubt = |d: Doubt| match d {
        Doubt::Jump => "jump",
        Doubt::Kink => "kink",
        Doubt::Corner => "corner",
        Doubt::Wall => "wall",
        Doubt::Fold => "fold",
        Doubt::Far => "far",
    };
    let point =
        |p: glam::DVec3| serde_json::json!([json_number(p.x), json_number(p.y), json_number(p.z)]);
    serde_json::json!({
        "vertices": mesh.positions.len(),
        "triangles": mesh.triangles.len(),
        "components": m.topology.components,
        "euler": m.topology.euler,
        "depth": m.level,
        "cells": m.cells,
        "discontinuous_cells": m.discontinuous_cells,
        "witnesses": {
            "root": mesh.count(Witness::Root),
            "tolerance": mesh.count(Witness::Tolerance),
            "wall": mesh.count(Witness::Wall),
            "uncertain": mesh.count(Witness::Uncertain),
        },
        "reach": json_number(reach),
        "tolerance": json_number(c.tolerance),
        "certified": c.certified,
        "hausdorff": json_number(c.hausdorff),
        "mesh_to_surface": json_number(c.mesh_to_surface),
        "surface_to_mesh": json_number(c.surface_to_mesh),
        "sharp_cells": m.sharpened.cells,
        "crease_face_vertices": m.sharpened.face_vertices,
        "uncertified": c.uncertified.iter().map(|u| serde_json::json!({
            "lo": point(u.cell.lo),
            "hi": point(u.cell.hi),
            "doubt": doubt(u.doubt),
        })).collect::<Vec<_>>(),
    })
}

/// Warnings and notes on stderr, after either summary: each names how many
/// objects of a scene it is about, and the first.
fn notes(objects: &[Object], depth: u32, scene: bool) {
    let say = |what: &str, which: &dyn Fn(&Meshed) -> Option<String>| {
        let mut hit = objects.iter().filter_map(|o| Some((o, which(&o.meshed)?)));
        let Some((first, text)) = hit.next() else {
            return;
        };
        let more = hit.count();
        match (scene, more) {
            (false, _) => eprintln!("{what}: {text}"),
            (true, 0) => eprintln!("{what}: {}: {text}", first.name),
            (true, n) => eprintln!(
                "{what}: {} and {n} more object{}: {text}",
                first.name,
                if n == 1 { "" } else { "s" }
            ),
        }
    };
    let budget = match scene {
        true => "the cells --max-cells leaves it (a scene's objects share them)",
        false => "--max-cells cells",
    };
    say("warning", &|m| {
        (m.level < depth).then(|| {
            format!(
                "the lattice stopped at depth {} of {depth}: depth {} would keep more than {budget}",
                m.level,
                m.level + 1
            )
        })
    });
    let larger = match scene {
        true => "the object's box does not hold its whole surface",
        false => "a larger --box holds the whole surface",
    };
    say("note", &|m| {
        let wall = m.mesh.count(Witness::Wall);
        (wall > 0).then(|| {
            format!("the solid f < 0 reaches the box's wall: {wall} vertices close the mesh just inside it ({larger})")
        })
    });
    say("note", &|m| {
        let far = m.certificate.count(Doubt::Far);
        (far > 0).then(|| {
            format!("{far} cells are isotopic to the surface but not proved within the tolerance of it: each level of --depth about quarters the distance the proof finds, or a larger --tolerance takes it")
        })
    });
    say("warning", &|m| {
        let uncertain = m.mesh.count(Witness::Uncertain);
        (uncertain > 0).then(|| {
            format!("{uncertain} vertices are on edges where f may jump or lack a value, so a change of sign there need not be a root")
        })
    });
}
