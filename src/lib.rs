//! lgc compiles an implicit surface `f(x, y, z) = 0` into what a guaranteed ray
//! tracer needs (exact symbolic derivatives, one compiled tape for every
//! evaluator, sound Lipschitz bounds L and G, octree pruning) and renders it
//! with Kalra and Barr's guaranteed ray intersection.
//!
//! The modules are the stages of that pipeline, each depending only on the
//! ones before it: [`types`] (intervals, boxes) ← [`expr`] (graphs, tapes) ←
//! [`lang`] (text) ← [`Formula`] ← [`bounds`] ← [`ray`] ← [`scene`] ←
//! [`mesh`] ← [`render`].
//!
//! # A tour of the pipeline
//!
//! **1. Text to syntax tree.** A `logos` lexer feeds a lalrpop parser; the tree
//! lives in a flat arena, so deep nesting never recurses. Mistakes come back as
//! a [`FormulaError`] that renders with a caret under the offending text:
//!
//! ```
//! let source = "sn(x) + 1";
//! let err = lgc::Formula::parse(source).unwrap_err();
//! assert_eq!(err.message, "unknown function `sn`, did you mean `sin`?");
//! assert!(err.render(source, "<formula>").contains("<formula>:1:1"));
//! ```
//!
//! **2. Expression graph.** Names are resolved into a hash-consed [`Context`]
//! whose builders fold constants and identities as they go:
//!
//! ```
//! use lgc::{Context, Var};
//! let mut ctx = Context::new();
//! let x = ctx.var(Var::X);
//! let zero = ctx.constant(0.0);
//! let one = ctx.constant(1.0);
//! let sum = ctx.add(x, zero);
//! assert_eq!(ctx.mul(sum, one), x);
//! ```
//!
//! **3. Symbolic derivatives.** [`Formula`] holds f, ∇f, the directional
//! derivative `g = d·∇f` (the ray direction is the extra inputs `dx dy dz`)
//! and `g′ = dᵀHd`, all printable as formulas that parse back:
//!
//! ```
//! let f = lgc::Formula::parse("x^3 + y*z").unwrap();
//! assert_eq!(f.print(f.gradient()[0]), "3*x^2");
//! assert_eq!(f.print(f.g()), "3*x^2*dx+(dy*z+y*dz)");
//! ```
//!
//! **4. Tape.** Any set of outputs compiles into one flat [`Tape`] with reused
//! slots; an [`Evaluator`] runs it at a point in any [`TapeValue`] type, a
//! [`PointEvaluator`] runs it as machine code (Cranelift) with the same bits,
//! and a [`BatchEvaluator`] runs it over many points per call:
//!
//! ```
//! use lgc::{Formula, Output, Evaluator, PointEvaluator, BatchEvaluator};
//! let f = Formula::parse("x^2 + y^2 + z^2 - 1").unwrap();
//! let tape = f.tape(&[Output::F, Output::G, Output::Dg]);
//! // At (1, 2, 0), along d = (1, 0, 0): f = 4, g = 2x = 2, g′ = 2|d|² = 2.
//! let mut point = Evaluator::<f64>::new(&tape);
//! assert_eq!(point.eval(&[1.0, 2.0, 0.0, 1.0, 0.0, 0.0]), &[4.0, 2.0, 2.0]);
//! let mut code = PointEvaluator::compiled(&tape);
//! assert_eq!(code.eval_array(&[1.0, 2.0, 0.0, 1.0, 0.0, 0.0]), [4.0, 2.0, 2.0]);
//!
//! let xs = [0.0, 1.0, 2.0];
//! let zeros = [0.0; 3];
//! let mut fs = [0.0; 3];
//! let mut gs = [0.0; 3];
//! let mut dgs = [0.0; 3];
//! BatchEvaluator::new(&tape).eval(
//!     &[&xs, &zeros, &zeros, &[1.0; 3], &zeros, &zeros],
//!     &mut [&mut fs, &mut gs, &mut dgs],
//! );
//! assert_eq!(fs, [-1.0, 0.0, 3.0]);
//! ```
//!
//! **5. Sound bounds.** The same tape runs in [`Interval`] arithmetic, whose
//! every result encloses the true one. From it come L, a bound of `|∇f|` over
//! a box, and G, a bound of `|g′|` along a ray segment, each piece enclosed
//! by the tightest [`bounds::Method`] that applies (interval extension,
//! centred form, Bernstein form, Taylor models); [`verify_lipschitz`] proves
//! or refutes a hand-derived constant, and [`bounds::bracket_lipschitz`]
//! brackets the true one:
//!
//! ```
//! use glam::DVec3;
//! use lgc::{Formula, Interval, Verdict, verify_lipschitz};
//! use lgc::{Aabb, Segment};
//! use lgc::bounds::Bounder;
//! let f = Formula::parse("x^2 + y^2 + z^2 - 1").unwrap();
//! let bounder = Bounder::new(&f);
//! let unit = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
//! assert!(bounder.lipschitz_bound(&unit, 0).value >= 2.0 * 3f64.sqrt());
//! let ray = Segment::new(DVec3::ZERO, DVec3::new(1.0, 2.0, 2.0), 0.0, 1.0).unwrap();
//! assert_eq!(bounder.grad_lipschitz_bound(&ray, 0).value, 18.0); // 2|d|²
//! let verdict = verify_lipschitz(&bounder, &unit, Interval::point(3.0), 1000);
//! assert!(matches!(verdict, Verdict::Refuted { .. })); // |∇f| reaches 2√3 > 3
//! let bracket = lgc::bounds::bracket_lipschitz(&bounder, &unit, 1e-6, 1000);
//! assert!(bracket.lower <= 2.0 * 3f64.sqrt() && 2.0 * 3f64.sqrt() <= bracket.upper);
//! ```
//!
//! **6. Guaranteed rays and pictures.** An [`ray::Intersector`] prunes the box
//! with an [`ray::Octree`] and answers rays with Kalra and Barr's method;
//! [`render::render`] shades a [`render::Camera`]'s rays with it, through the
//! tile loop every integrator shares ([`render::film`]):
//!
//! ```
//! use glam::DVec3;
//! use lgc::{Aabb, Formula, ray::Intersector};
//! let f = Formula::parse("x^2 + y^2 + z^2 - 1").unwrap();
//! let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
//! let scene = Intersector::new(&f, &b, 5);
//! let mut tracer = scene.tracer();
//! let t = tracer.first_hit(DVec3::new(-3.0, 0.0, 0.0), DVec3::X, 0.0, f64::INFINITY);
//! assert_eq!(t, Some(2.0));
//! // A ray that passes 1e-9 above the sphere is a miss, not a guess: every
//! // answer carries a certificate (a proven sign change for a hit, every
//! // piece excluded for a miss, an enclosure holding 0 for a touch).
//! use lgc::ray::Answer;
//! let o = DVec3::new(-3.0, 1.0 + 1e-9, 0.0);
//! assert_eq!(tracer.answer(o, DVec3::X, 0.0, f64::INFINITY), Answer::Miss);
//!
//! // Camera rays of one tile leave the eye as a bundle: the space in front
//! // of the surface is proved empty for all of them at once, and each ray
//! // starts there.
//! let eye = DVec3::new(-3.0, 0.0, 0.0);
//! let tile = [DVec3::X, DVec3::new(1.0, 0.01, 0.0), DVec3::new(1.0, 0.0, 0.01)];
//! let clear = lgc::ray::bundle::clear_until(&mut tracer, &scene.bounds(), eye, &tile, 0.0);
//! assert!(clear > 1.0 && clear <= 2.0); // the box starts at 1, the sphere at 2
//! assert_eq!(tracer.first_hit(eye, DVec3::X, clear, f64::INFINITY), Some(2.0));
//! ```
//!
//! A CSG shape is a `min`/`max` of formulas, with a crease where G is
//! infinite. Each octree leaf sees the formula with the branches that hold
//! over its box settled, so away from the crease it is smooth again; a leaf
//! the crease crosses keeps both smooth sides, and each piece of a ray there
//! runs the tests of the side it is proved to be on, or, where no side holds
//! and both are quadratic, is answered in closed form. Rays search a leaf only
//! within its hull, the sub-boxes of its box that no test proves empty:
//!
//! ```
//! use glam::DVec3;
//! use lgc::{Aabb, Formula, ray::Octree};
//! let cut_ball = Formula::parse("max(x^2 + y^2 + z^2 - 1, z - 0.3)").unwrap();
//! let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
//! let tree = Octree::build(&cut_ball, &b, 4);
//! // The ball, the plane, and the whole formula where the crease may cross.
//! assert_eq!(tree.shapes.len(), 3);
//! assert!(tree.stats.specialised > 0);
//! assert_eq!(tree.stats.split, tree.stats.creased);
//!
//! // Each leaf's hull: the part of its box that can hold the surface, the
//! // only part rays search (reaching the pad beyond the box's own faces,
//! // where rounding may put a root on the wall). Many are thinner than
//! // their boxes.
//! let leaves = tree.nodes.iter().filter_map(|n| Some((n, n.leaf_index()?)));
//! for (node, i) in leaves {
//!     let (hull, pad) = (tree.leaf_hull(i), 2.0 * tree.pad);
//!     assert!(hull.lo.cmpge(node.bounds.lo - pad).all());
//!     assert!(hull.hi.cmple(node.bounds.hi + pad).all());
//! }
//! assert!(tree.nodes.iter().any(|n| n.is_tight()));
//!
//! // A ray onto the flat top 0.005 inside its rim, where both sides are
//! // near 0: both are quadratic along it (a sphere, a plane), so the piece
//! // is answered from their values at its middle, in closed form, proved
//! // by their Taylor bounds. The search's answer, for fewer evaluations.
//! use lgc::ray::{Answer, Intersector as Scene};
//! let scene = Scene::new(&cut_ball, &b, 4);
//! let (o, d) = (DVec3::new(0.0, -3.0, 0.505), DVec3::new(0.0, 1.0, -0.1));
//! let (mut solved, mut searched) = (scene.tracer(), scene.tracer());
//! searched.set_closed_form_seams(false);
//! let (Answer::Hit(t), Answer::Hit(s)) = (
//!     solved.answer(o, d, 0.0, f64::INFINITY),
//!     searched.answer(o, d, 0.0, f64::INFINITY),
//! ) else { panic!("both hit the top") };
//! assert!((t - 2.05).abs() < 1e-9 && (t - s).abs() < 1e-9);
//! assert!(solved.stats.seams > 0 && solved.stats.f_evals < searched.stats.f_evals);
//!
//! // A tile's camera rays list the leaves they may cross (one walk of the
//! // octree for all of them), prove the space before the surface empty over
//! // that list, and each ray searches the listed leaves instead of walking:
//! // the same answers.
//! use lgc::ray::{bundle::{clear_until_listed, LeafList}, Intersector};
//! let scene = Intersector::new(&cut_ball, &b, 4);
//! let mut tracer = scene.tracer();
//! let eye = DVec3::new(0.0, -3.0, 0.1);
//! let tile = [DVec3::Y, DVec3::new(0.01, 1.0, 0.0), DVec3::new(0.0, 1.0, 0.01)];
//! let mut list = LeafList::default();
//! assert!(list.gather(&tracer, eye, &tile, 0.0) && !list.is_empty());
//! let clear = clear_until_listed(&mut tracer, &b, &list);
//! list.advance(clear);
//! assert!(clear > 1.0 && clear <= 2.0); // the box starts at 1, the ball at 2
//! let t = tracer.first_hit_in(&list, eye, DVec3::Y, clear);
//! assert_eq!(t, tracer.first_hit(eye, DVec3::Y, 0.0, f64::INFINITY));
//! assert!((t.unwrap() - (3.0 - (1.0f64 - 0.01).sqrt())).abs() < 1e-9);
//! ```
//!
//! A polynomial with no branch point (here a torus) needs no octree walk:
//! along a ray it is a polynomial in t, whose coefficients jets compute
//! with a bound of their error; its Bernstein coefficients exclude pieces
//! of the ray or isolate the first root, certified by signs either side:
//!
//! ```
//! use glam::DVec3;
//! use lgc::{Aabb, Formula, ray::{octree::BuildOptions, Answer, Intersector}};
//! let torus = Formula::parse("(x^2 + y^2 + z^2 + 0.75)^2 - 4*(x^2 + y^2)").unwrap();
//! let b = Aabb::new(DVec3::new(-2.0, -2.0, -1.0), DVec3::new(2.0, 2.0, 1.0)).unwrap();
//! let scene = Intersector::new(&torus, &b, 5);
//! let search_only = BuildOptions { polynomial_form: false, ..BuildOptions::to_depth(5) };
//! let reference = Intersector::with_options(&torus, &b, &search_only);
//! let (mut bernstein, mut searched) = (scene.tracer(), reference.tracer());
//! assert!(bernstein.closed_form() && !searched.closed_form());
//! // Down the x axis from afar: the tube's outer side at x = 1.5.
//! let (o, d) = (DVec3::new(4.0, 0.0, 0.0), DVec3::new(-1.0, 0.0, 0.0));
//! let (Answer::Hit(t), Answer::Hit(s)) = (
//!     bernstein.answer(o, d, 0.0, f64::INFINITY),
//!     searched.answer(o, d, 0.0, f64::INFINITY),
//! ) else { panic!("both hit the tube") };
//! assert!((t - 2.5).abs() < 1e-9 && (t - s).abs() < 1e-9);
//! assert_eq!(bernstein.stats.closed_form, 1);
//! // Through the hole, along z: no root, every piece excluded.
//! let up = DVec3::Z;
//! assert_eq!(bernstein.answer(DVec3::new(0.0, 0.0, -3.0), up, 0.0, f64::INFINITY), Answer::Miss);
//! ```
//!
//! **7. Meshes.** [`mesh::mesh`] splits the box into a lattice, drops the
//! cells whose enclosure of f excludes 0, and cuts each remaining cell's six
//! tetrahedra between the lattice points proved inside and outside. The
//! triangles separate lattice points, so the mesh is a closed 2-manifold
//! whatever f does, and bisection on proved signs puts every vertex within
//! a sixteenth of the tolerance of a root. In a certified cell the mesh is
//! isotopic to the surface and within the tolerance of it, both ways (by
//! default a quarter of a cell's side):
//!
//! ```
//! use glam::DVec3;
//! use lgc::{Aabb, Formula, mesh::{mesh, MeshOptions, Witness}};
//! let torus = Formula::parse("(sqrt(x^2 + y^2) - 1)^2 + z^2 - 0.25^2").unwrap();
//! let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
//! let options = MeshOptions { depth: 7, tolerance: None, max_cells: 1 << 20 };
//! let m = mesh(&torus, &b, &options).unwrap();
//! assert!(m.topology.closed && m.topology.manifold);
//! assert_eq!((m.topology.euler, m.topology.components), (0, 1)); // genus 1
//! let c = &m.certificate;
//! assert!(m.mesh.radii.iter().all(|&r| r <= c.tolerance / 16.0));
//! assert!(m.mesh.witnesses.iter().all(|&w| w == Witness::Root || w == Witness::Tolerance));
//! assert!(c.certified > c.uncertified.len() && c.hausdorff <= c.tolerance);
//! ```

#![warn(missing_docs)]

pub mod bounds;
pub mod expr;
pub mod file;
mod formula;
pub mod lang;
pub mod mesh;
pub mod proof;
pub mod ray;
pub mod render;
pub mod scene;
pub mod types;

pub use bounds::{verify_grad_lipschitz, verify_lipschitz, Bound, Bounder, Verdict};
pub use expr::{
    to_source, BatchEvaluator, BinaryOp, Context, DecoratedEvaluator, Evaluator, Node, Op,
    PointEvaluator, Tape, TapeValue, UnaryOp, Var,
};
pub use formula::{Formula, Output};
pub use lang::{ErrorKind, FormulaError};
pub use types::{Aabb, Interval, Segment};
