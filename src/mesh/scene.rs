//! A scene's objects meshed one by one, each in its own box and its own
//! coordinates, then placed in the scene with every bound carried over.
//!
//! An object's surface in the scene is `offset + scale·q` for the points q
//! of its own surface. A mesh vertex p proved within r of a root w becomes
//! `fl(fl(scale·p) + offset)`, which is within `scale·r` of the root
//! `offset + scale·w` plus the two roundings of each coordinate: at most
//! γ₂·(|offset| + scale·|p|) a coordinate. The same slack widens each
//! uncertified cell and the Hausdorff bound.

use super::{mesh_with_room, single_rounding, MeshError, MeshOptions, Meshed, Progress};
use crate::scene::{Placement, Scene, SceneObject};
use crate::types::rounding::{gamma, up_bound};
use crate::types::{Aabb, Interval};
use glam::DVec3;
use std::sync::Arc;

/// Meshes every object of `scene`, each in its own box, with `options` in
/// scene units; the meshes are in scene coordinates, in the scene's order.
pub fn mesh_scene(scene: &Scene, options: &MeshOptions) -> Result<Vec<Meshed>, MeshError> {
    mesh_scene_with_progress(scene, options, &|_, _| {})
}

/// [`mesh_scene`], telling `report` which object (counted from 0) is at
/// which stage.
///
/// `options.max_cells` bounds the cells of all objects together, so memory
/// stays bounded however many objects the scene has: each object may keep
/// what the ones before it left, and stops at a coarser level (which its
/// [`Meshed::level`] says) when that is too little. Objects of the same
/// shape and box share one mesh, placed once for each.
pub fn mesh_scene_with_progress(
    scene: &Scene,
    options: &MeshOptions,
    report: &(dyn Fn(usize, Progress) + Sync),
) -> Result<Vec<Meshed>, MeshError> {
    // How far placing a vertex in the scene and rounding it to f32 may
    // move it, at most, over every object: one room for all, so objects of
    // one shape and size share a mesh.
    let room = scene
        .objects
        .iter()
        .map(|o| {
            let b = &o.local_bounds;
            up_bound(slack(b.lo.abs().max(b.hi.abs()), &o.placement) + single_rounding(&o.bounds))
        })
        .fold(0.0, f64::max);
    // Each mesh made, with its object.
    let mut shared: Vec<(&SceneObject, Meshed)> = Vec::new();
    let mut left = options.max_cells;
    let mut out = Vec::with_capacity(scene.objects.len());
    for (i, object) in scene.objects.iter().enumerate() {
        let p = object.placement;
        let scale = Interval::point(p.scale);
        // A mesh of the same shape, box and size that fits in what is left.
        let same = |(o, m): &&(&SceneObject, Meshed)| {
            Arc::ptr_eq(&o.formula, &object.formula)
                && o.local_bounds == object.local_bounds
                && o.placement.scale == p.scale
                && m.cells <= left
        };
        let local = match shared.iter().find(same) {
            Some((_, m)) => m.clone(),
            None => {
                let budget = MeshOptions {
                    tolerance: options
                        .tolerance
                        .map(|t| (Interval::point(t) / scale).inf().max(f64::MIN_POSITIVE)),
                    max_cells: left.max(1),
                    ..*options
                };
                let room = (Interval::point(room) / scale).sup();
                let m = mesh_with_room(
                    &object.formula,
                    &object.local_bounds,
                    &budget,
                    room,
                    &|stage| report(i, stage),
                )?;
                shared.push((object, m.clone()));
                m
            }
        };
        left = left.saturating_sub(local.cells);
        let tolerance = match options.tolerance {
            Some(t) => t,
            None => up_bound(p.scale * local.certificate.tolerance),
        };
        out.push(placed(local, &p, tolerance));
    }
    Ok(out)
}

/// How far rounding may move `p`'s image under `p ↦ offset + scale·p`.
fn slack(p: DVec3, placement: &Placement) -> f64 {
    let size = placement.offset.abs() + placement.scale * p.abs();
    gamma(2) * size.length()
}

/// A mesh in an object's coordinates, moved into the scene's, where its
/// certified cells are within `tolerance` of the surface (certification
/// left room for the move).
pub fn placed(mut m: Meshed, placement: &Placement, tolerance: f64) -> Meshed {
    if *placement == Placement::IDENTITY {
        m.certificate.tolerance = tolerance;
        return m;
    }
    let scale = placement.scale;
    let mut moved: f64 = 0.0;
    for (p, r) in m.mesh.positions.iter_mut().zip(&mut m.mesh.radii) {
        let s = slack(*p, placement);
        moved = moved.max(s);
        *r = up_bound(scale * *r + s);
        *p = placement.offset + scale * *p;
    }
    let c = &mut m.certificate;
    for u in &mut c.uncertified {
        let b = placement.to_scene(&u.cell);
        let pad = slack(u.cell.lo, placement).max(slack(u.cell.hi, placement));
        u.cell = Aabb {
            lo: b.lo - DVec3::splat(up_bound(pad)),
            hi: b.hi + DVec3::splat(up_bound(pad)),
        };
    }
    c.moved(scale, moved, tolerance);
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Doubt, Witness};
    use crate::scene::parse_scene;

    /// Every vertex of a placed sphere is within its radius of the sphere
    /// the scene describes.
    #[test]
    fn placed_vertices_stay_within_their_radii() {
        let scene =
            parse_scene("sphere { center = (1e3, -2, 0.5); radius = 0.75; }").expect("a scene");
        let options = MeshOptions {
            depth: 4,
            tolerance: Some(1e-6),
            max_cells: 1 << 20,
        };
        let meshed = mesh_scene(&scene, &options).expect("a mesh");
        let m = &meshed[0].mesh;
        assert!(!m.positions.is_empty());
        let centre = DVec3::new(1e3, -2.0, 0.5);
        for ((p, r), w) in m.positions.iter().zip(&m.radii).zip(&m.witnesses) {
            assert_eq!(*w, Witness::Root);
            let off = ((*p - centre).length() - 0.75).abs();
            assert!(off <= *r, "{p} is {off} from the sphere, radius {r}");
            assert!(*r <= 2e-6, "radius {r} past the tolerance");
        }
        // Rounding to f32 near x = 1000 may move a vertex 6e-5, past the
        // tolerance: no cell is certified within it.
        let c = &meshed[0].certificate;
        assert_eq!((c.certified, c.tolerance), (0, 1e-6));
        assert!(c.count(Doubt::Far) > 0);
        // The default tolerance is a quarter of a cell of the sphere's own
        // box, in scene units, and leaves room for the moves.
        let options = MeshOptions {
            tolerance: None,
            ..options
        };
        let c = &mesh_scene(&scene, &options).expect("a mesh")[0].certificate;
        let b = &scene.objects[0].bounds;
        let side = (b.hi - b.lo).min_element() / 16.0;
        assert!(
            (c.tolerance / (side * crate::mesh::DEFAULT_TOLERANCE) - 1.0).abs() < 1e-9,
            "{}",
            c.tolerance
        );
        assert!(c.certified > 0 && c.hausdorff <= c.tolerance);
    }

    /// Five spheres share a cell budget: their cells together stay within
    /// it, the later ones on coarser lattices; spheres of one size share a
    /// mesh, moved.
    #[test]
    fn objects_share_the_cell_budget_and_equal_shapes_share_a_mesh() {
        let text = "sphere { center = (0, 0, 0); radius = 1; }
            sphere { center = (3, 0, 0); radius = 1; }
            sphere { center = (6, 0, 0); radius = 1; }
            sphere { center = (9, 0, 0); radius = 1; }
            sphere { center = (12, 0, 0); radius = 1; }";
        let scene = parse_scene(text).expect("a scene");
        let unbounded = MeshOptions {
            depth: 5,
            tolerance: Some(1e-4),
            max_cells: 1 << 20,
        };
        let all = mesh_scene(&scene, &unbounded).expect("meshes");
        let one = all[0].cells;
        for (k, m) in all.iter().enumerate() {
            assert_eq!(m.level, 5);
            assert_eq!(m.mesh.triangles, all[0].mesh.triangles);
            let shift = DVec3::new(3.0 * k as f64, 0.0, 0.0);
            for (p, q) in m.mesh.positions.iter().zip(&all[0].mesh.positions) {
                assert!((*p - shift - *q).length() <= 1e-14 * (1.0 + p.length()));
            }
        }
        let budget = 2 * one + one / 2;
        let bounded = MeshOptions {
            max_cells: budget,
            ..unbounded
        };
        let some = mesh_scene(&scene, &bounded).expect("meshes");
        let total: usize = some.iter().map(|m| m.cells).sum();
        assert!(total <= budget + some.len(), "{total} cells past {budget}");
        let levels: Vec<u32> = some.iter().map(|m| m.level).collect();
        assert_eq!(&levels[..2], &[5, 5]);
        assert!(levels[2..].iter().all(|&l| l < 5), "{levels:?}");
        assert!(some
            .iter()
            .all(|m| m.topology.closed && m.topology.manifold));
    }
}
