//! The command line: the subcommands, one file each, over shared options in
//! [`args`]. Only the binary uses this module.

mod args;
mod bench;
mod bounds;
mod check_proof;
mod eval;
mod grad;
mod mesh;
mod plot;
mod render;
mod trace;
mod verify;

pub use args::Failure;
use clap::{Parser, Subcommand};

/// Compile an implicit surface f(x,y,z) = 0 into exact derivatives, sound
/// Lipschitz bounds and guaranteed ray intersections; render formulas and scenes.
#[derive(Parser, Debug)]
#[command(name = "lgc", version, after_long_help = lgc::lang::functions::language_reference())]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the simplified partial derivatives of f (and with --directional, g and g').
    #[command(after_long_help = lgc::lang::functions::language_reference())]
    // A negative number is an option's value (for its range message), never
    // a flag: `--fov -5` must not suggest `-- -5`.
    #[command(allow_negative_numbers = true)]
    Grad(grad::GradArgs),
    /// Evaluate f and its gradient (and g, g' with --dir) at a point.
    #[command(after_long_help = lgc::lang::functions::language_reference())]
    // A negative number is an option's value (for its range message), never
    // a flag: `--fov -5` must not suggest `-- -5`.
    #[command(allow_negative_numbers = true)]
    Eval(eval::EvalArgs),
    /// Sound bounds over a box: the interval of f and L >= max |grad f| (with
    /// --ray, G >= max |g'| on a segment), each beside a sampled estimate.
    #[command(after_long_help = bounds::HELP)]
    // A negative number is an option's value (for its range message), never
    // a flag: `--fov -5` must not suggest `-- -5`.
    #[command(allow_negative_numbers = true)]
    // `--corpus` names the formulas instead.
    #[command(mut_arg("expr", |a| a.required_unless_present_any(["file", "corpus"])))]
    Bounds(bounds::BoundsArgs),
    /// Render the surface to an image (PNG or PPM, by extension), with no
    /// missed surface: every ray is answered by the guaranteed intersector.
    #[command(after_long_help = SCENE_HELP)]
    // A negative number is an option's value (for its range message), never
    // a flag: `--fov -5` must not suggest `-- -5`.
    #[command(allow_negative_numbers = true)]
    Render(render::RenderArgs),
    /// Mesh the surface: a closed, 2-manifold triangle mesh without
    /// self-intersections, every vertex within a proved distance of the
    /// surface (STL, OBJ, PLY, glTF binary or 3MF, by extension).
    // A negative number is an option's value (for its range message), never
    // a flag: `--fov -5` must not suggest `-- -5`.
    #[command(allow_negative_numbers = true)]
    Mesh(mesh::MeshArgs),
    /// Benchmark: render corpus surfaces (no files written) and report time,
    /// rays per second, and f and interval evaluations per ray.
    // A negative number is an option's value (for its range message), never
    // a flag: `--fov -5` must not suggest `-- -5`.
    #[command(allow_negative_numbers = true)]
    Bench(bench::BenchArgs),
    /// Guaranteed first hits: reads rays "ox oy oz dx dy dz" from standard input,
    /// one per line, and prints for each the first hit t (o + t*d, t >= 0, inside
    /// the box), "touch t" (a tangency or a graze within the tolerance), or "none".
    // A negative number is an option's value (for its range message), never
    // a flag: `--fov -5` must not suggest `-- -5`.
    #[command(allow_negative_numbers = true)]
    Trace(trace::TraceArgs),
    /// Prove or refute a hand-derived constant: max |grad f| <= C on the box, or
    /// max |g'| <= C on a ray segment. Exit 0 proved, 3 refuted, 4 undecided.
    // A negative number is an option's value (for its range message), never
    // a flag: `--fov -5` must not suggest `-- -5`.
    #[command(allow_negative_numbers = true)]
    Verify(verify::VerifyArgs),
    /// Re-check a proof file written by `lgc verify --proof`, with a checker
    /// that shares only the parser and the interval type with the prover.
    /// Exit 0 valid, 1 not.
    CheckProof(check_proof::CheckProofArgs),
}

const SCENE_HELP: &str = "SCENE FILES (lgc render scene.lgc)\n  \
let and fn bindings, then blocks:\n  \
camera { eye = (x, y, z); look_at = (x, y, z); up = (0, 0, 1); fov = 30; }\n  \
light { position = (x, y, z); color = (1, 1, 1); intensity = 1; }   (or direction = ...)\n  \
material NAME { color = (r, g, b); diffuse; specular; shininess; reflect; transparency; ior; checker; tile; }\n  \
object { surface = FORMULA; box = (x0, y0, z0, x1, y1, z1); material = NAME; }\n  \
sphere { center; radius; }  plane { normal; offset; extent; }  box { min; max; }\n  \
torus { center; major; minor; }  cylinder { center; radius; height; }\n  \
CSG in formulas: union intersect subtract blend translate rotate scale.\n  \
Command-line options override the file. See docs/scenes.md for the full reference.";

/// Runs the parsed command line; `Ok` carries the exit code of an answer.
pub fn run(cli: Cli) -> Result<u8, Failure> {
    match &cli.command {
        Command::Grad(args) => grad::run(args),
        Command::Eval(args) => eval::run(args),
        Command::Bounds(args) => bounds::run(args),
        Command::Render(args) => render::run(args),
        Command::Mesh(args) => mesh::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Trace(args) => trace::run(args),
        Command::Verify(args) => verify::run(args),
        Command::CheckProof(args) => check_proof::run(args),
    }
}
