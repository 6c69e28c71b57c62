//! Draws a mesh made by `lgc::mesh` as flat-shaded triangles with their
//! edges, the way a mesh viewer shows it: a cube drilled through along three
//! axes (genus 5), at depth 4 so that the triangles can be seen.
//!
//! ```sh
//! cargo run --release --example mesh_picture -- docs/gallery/mesh/drilled_cube.png
//! ```

use glam::DVec3;
use lgc::mesh::{mesh, MeshOptions};
use lgc::{Aabb, Formula};

const DRILLED_CUBE: &str = "max(max(max(abs(x),abs(y)),abs(z))-1, \
     -min(min(sqrt(x^2+y^2)-0.5, sqrt(y^2+z^2)-0.5), sqrt(x^2+z^2)-0.5))";

const WIDTH: usize = 800;
const HEIGHT: usize = 600;

fn main() {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "drilled_cube.png".into());
    let f = Formula::parse(DRILLED_CUBE).expect("the formula parses");
    let b = Aabb::new(DVec3::splat(-1.3), DVec3::splat(1.3)).expect("a box");
    let options = MeshOptions {
        depth: 4,
        tolerance: Some(1e-4),
        max_cells: 1 << 20,
    };
    let m = mesh(&f, &b, &options).expect("the mesh is made").mesh;

    let eye = DVec3::new(4.0, -5.0, 3.2);
    // A pinhole camera looking at the origin, 30° across vertically.
    let forward = (-eye).normalize();
    let right = forward.cross(DVec3::Z).normalize();
    let up = right.cross(forward);
    let focal = 0.5 * HEIGHT as f64 / (15f64.to_radians()).tan();
    let to_screen = |p: DVec3| {
        let d = p - eye;
        let z = d.dot(forward);
        DVec3::new(
            0.5 * WIDTH as f64 + focal * d.dot(right) / z,
            0.5 * HEIGHT as f64 - focal * d.dot(up) / z,
            z,
        )
    };
    let light = DVec3::new(0.4, -0.6, 0.7).normalize();
    let mut depth = vec![f64::INFINITY; WIDTH * HEIGHT];
    let mut rgb = vec![255u8; 3 * WIDTH * HEIGHT];

    // Flat-shaded triangles, nearest kept.
    for t in &m.triangles {
        let world = t.map(|v| m.positions[v as usize]);
        let normal = (world[1] - world[0])
            .cross(world[2] - world[0])
            .normalize_or_zero();
        let shade = 0.25 + 0.75 * normal.dot(light).abs();
        let colour = [0.55 * shade, 0.68 * shade, 0.85 * shade].map(|c| (255.0 * c) as u8);
        let s = world.map(to_screen);
        let (lo_x, hi_x) = (
            s.iter().map(|p| p.x).fold(f64::MAX, f64::min),
            s.iter().map(|p| p.x).fold(f64::MIN, f64::max),
        );
        let (lo_y, hi_y) = (
            s.iter().map(|p| p.y).fold(f64::MAX, f64::min),
            s.iter().map(|p| p.y).fold(f64::MIN, f64::max),
        );
        let area = edge(s[0], s[1], s[2]);
        if area == 0.0 {
            continue;
        }
        for y in (lo_y.max(0.0) as usize)..=(hi_y.min(HEIGHT as f64 - 1.0) as usize) {
            for x in (lo_x.max(0.0) as usize)..=(hi_x.min(WIDTH as f64 - 1.0) as usize) {
                let p = DVec3::new(x as f64 + 0.5, y as f64 + 0.5, 0.0);
                let w = [
                    edge(s[1], s[2], p),
                    edge(s[2], s[0], p),
                    edge(s[0], s[1], p),
                ]
                .map(|w| w / area);
                if w.iter().any(|&w| w < 0.0) {
                    continue;
                }
                let z = w[0] * s[0].z + w[1] * s[1].z + w[2] * s[2].z;
                let k = y * WIDTH + x;
                if z < depth[k] {
                    depth[k] = z;
                    rgb[3 * k..3 * k + 3].copy_from_slice(&colour);
                }
            }
        }
    }
    // Edges on top, where they are not hidden (a small bias keeps a
    // triangle's own edges in front of it).
    for t in &m.triangles {
        let s = t.map(|v| to_screen(m.positions[v as usize]));
        for k in 0..3 {
            let (a, b) = (s[k], s[(k + 1) % 3]);
            let steps = ((b - a).truncate().length().ceil() as usize).max(1);
            for i in 0..=steps {
                let p = a.lerp(b, i as f64 / steps as f64);
                let (x, y) = (p.x as usize, p.y as usize);
                if x < WIDTH && y < HEIGHT && p.z <= depth[y * WIDTH + x] + 2e-3 {
                    let k = y * WIDTH + x;
                    rgb[3 * k..3 * k + 3].copy_from_slice(&[40, 48, 64]);
                }
            }
        }
    }
    image::save_buffer(
        &out,
        &rgb,
        WIDTH as u32,
        HEIGHT as u32,
        image::ColorType::Rgb8,
    )
    .expect("the picture is written");
    println!("wrote {out}: {} triangles", m.triangles.len());
}

/// Twice the signed area of the screen triangle a b p.
fn edge(a: DVec3, b: DVec3, p: DVec3) -> f64 {
    (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
}
