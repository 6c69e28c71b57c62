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

/// Meshes every object of `scene`, each in its own box, with `options` in
/// scene units; the meshes are in scene coordinates, in the scene's order.
pub fn mesh_scene(scene: &Scene, options: &MeshOptions) -> Result<Vec<Meshed>, MeshError> {
    scene
        .objects
        .iter()
        .map(|o| mesh_object(o, options, &|_| {}))
        .collect()
}

/// Meshes one object of a scene in its own box and places the mesh in the
/// scene; the tolerance of `options` is in scene units.
pub fn mesh_object(
    object: &SceneObject,
    options: &MeshOptions,
    report: &(dyn Fn(Progress) + Sync),
) -> Result<Meshed, MeshError> {
    let p = object.placement;
    let local = MeshOptions {
        tolerance: options.tolerance / p.scale,
        ..*options
    };
    let meshed = mesh_with_progress(&object.formula, &object.local_bounds, &local, report)?;
    Ok(placed(meshed, &p))
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

    fn object_box_diagonal(scene: &Scene) -> f64 {
        scene.objects[0].bounds.diagonal()
    }
}
