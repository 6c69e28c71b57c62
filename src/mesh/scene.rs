//! A scene's objects meshed one by one, each in its own box and its own
//! coordinates, then placed in the scene with every bound carried over.
//!
//! An object's surface in the scene is `offset + scale·q` for the points q
//! of its own surface. A mesh vertex p proved within r of a root w becomes
//! `fl(fl(scale·p) + offset)`, which is within `scale·r` of the root
//! `offset + scale·w` plus the two roundings of each coordinate: at most
//! γ₂·(|offset| + scale·|p|) a coordinate. The same slack widens each
//! uncertified cell and the Hausdorff bound.

use super::{mesh_with_progress, MeshError, MeshOptions, Meshed, Progress};
use crate::scene::{Placement, Scene, SceneObject};
use crate::types::rounding::{gamma, up_bound};
use crate::types::Aabb;
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
    // Each mesh made, with its object and the tolerance it was made to.
    let mut shared: Vec<(&SceneObject, f64, Meshed)> = Vec::new();
    let mut left = options.max_cells;
    let mut out = Vec::with_capacity(scene.objects.len());
    for (i, object) in scene.objects.iter().enumerate() {
        let p = object.placement;
        let tolerance = options.tolerance / p.scale;
        // A mesh made to a tolerance no looser than this object's, that
        // fits in what is left.
        let same = |(o, t, m): &&(&SceneObject, f64, Meshed)| {
            Arc::ptr_eq(&o.formula, &object.formula)
                && o.local_bounds == object.local_bounds
                && *t <= tolerance
                && m.cells <= left
        };
        let local = match shared.iter().find(same) {
            Some((_, _, m)) => m.clone(),
            None => {
                let budget = MeshOptions {
                    tolerance,
                    max_cells: left.max(1),
                    ..*options
                };
                let m =
                    mesh_with_progress(&object.formula, &object.local_bounds, &budget, &|stage| {
                        report(i, stage)
                    })?;
                shared.push((object, tolerance, m.clone()));
                m
            }
        };
        left = left.saturating_sub(local.cells);
        out.push(placed(local, &p));
    }
    Ok(out)
}

/// How far rounding may move `p`'s image under `p ↦ offset + scale·p`.
fn slack(p: DVec3, placement: &Placement) -> f64 {
    let size = placement.offset.abs() + placement.scale * p.abs();
    gamma(2) * size.length()
}

/// A mesh in an object's coordinates, moved into the scene's.
pub fn placed(mut m: Meshed, placement: &Placement) -> Meshed {
    if *placement == Placement::IDENTITY {
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
    c.hausdorff = up_bound(scale * c.hausdorff + moved);
    // 0 says no triangle had the bound, and stays so.
    if c.mesh_to_surface > 0.0 {
        c.mesh_to_surface = up_bound(scale * c.mesh_to_surface + moved);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Witness;
    use crate::scene::parse_scene;

    /// Every vertex of a placed sphere is within its radius of the sphere
    /// the scene describes.
    #[test]
    fn placed_vertices_stay_within_their_radii() {
        let scene =
            parse_scene("sphere { center = (1e3, -2, 0.5); radius = 0.75; }").expect("a scene");
        let options = MeshOptions {
            depth: 4,
            tolerance: 1e-6,
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
        // The certificate's bound is in scene units: a cell of the sphere's
        // own box [-1.05, 1.05]³ (or thereabouts) over 16, scaled by 0.75.
        let h = meshed[0].certificate.hausdorff;
        let own = object_box_diagonal(&scene) / 16.0;
        assert!(h >= own && h <= own * 1.001, "{h} against {own}");
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
            tolerance: 1e-4,
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

    fn object_box_diagonal(scene: &Scene) -> f64 {
        scene.objects[0].bounds.diagonal()
    }
}
