//! Mesh files, the format chosen by the extension, each written by its own
//! crate into a temporary file beside the target and renamed into place, so
//! a failed write never leaves a half-written file.

use super::Mesh;
use crate::file::PendingFile;
use glam::DVec3;
use rayon::prelude::*;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;

/// The mesh formats, by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Binary STL (`.stl`), single precision.
    Stl,
    /// Wavefront OBJ (`.obj`), single precision.
    Obj,
    /// Binary little-endian PLY (`.ply`), double precision.
    Ply,
    /// glTF binary (`.glb`), single precision.
    Glb,
    /// 3D Manufacturing Format (`.3mf`), double precision.
    ThreeMf,
}

impl MeshFormat {
    /// The format a path's extension names.
    pub fn of(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "stl" => MeshFormat::Stl,
            "obj" => MeshFormat::Obj,
            "ply" => MeshFormat::Ply,
            "glb" => MeshFormat::Glb,
            "3mf" => MeshFormat::ThreeMf,
            _ => return None,
        })
    }

    /// Whether the format stores coordinates as f32 (so vertices move by
    /// up to half an f32 ulp of their coordinates).
    pub fn single_precision(self) -> bool {
        matches!(self, MeshFormat::Stl | MeshFormat::Obj | MeshFormat::Glb)
    }
}

/// One object of a mesh file: a formula's mesh, or one object of a scene.
#[derive(Debug, Clone, Copy)]
pub struct Part<'a> {
    /// Its name, where the format keeps names (OBJ, glTF, 3MF).
    pub name: &'a str,
    /// Its triangles.
    pub mesh: &'a Mesh,
    /// Its base colour, linear RGB in [0, 1], where the format keeps one
    /// (glTF).
    pub color: Option<[f32; 3]>,
}

/// Why a mesh could not be written.
pub type WriteError = crate::file::FileError;

/// A mesh file being prepared: the temporary file exists from the start, so
/// an unwritable destination is reported before any meshing is done.
#[derive(Debug)]
pub struct PendingMesh {
    file: PendingFile,
    format: MeshFormat,
}

impl PendingMesh {
    /// Checks the format and reserves a temporary file next to `target`.
    pub fn create(target: &Path) -> Result<PendingMesh, WriteError> {
        let format = MeshFormat::of(target).ok_or_else(|| WriteError::Format {
            path: target.display().to_string(),
            kind: "mesh",
            choices: ".stl, .obj, .ply, .glb or .3mf",
        })?;
        Ok(PendingMesh {
            file: PendingFile::create(target)?,
            format,
        })
    }

    /// The format being written.
    pub fn format(&self) -> MeshFormat {
        self.format
    }

    /// Writes the parts into the temporary file and renames it into place.
    pub fn finish(self, parts: &[Part]) -> Result<(), WriteError> {
        write_file(self.file.temp(), self.format, parts).map_err(|e| self.file.encode_error(e))?;
        self.file.rename()
    }
}

/// Writes `parts` to `path` in `format`.
fn write_file(path: &Path, format: MeshFormat, parts: &[Part]) -> Result<(), String> {
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let mut out = BufWriter::new(file);
    match format {
        MeshFormat::Stl => write_stl(&mut out, parts).map_err(|e| e.to_string())?,
        MeshFormat::Obj => write_obj(&mut out, parts).map_err(|e| e.to_string())?,
        MeshFormat::Ply => write_ply(&mut out, parts).map_err(|e| e.to_string())?,
        MeshFormat::Glb => write_glb(&mut out, parts)?,
        MeshFormat::ThreeMf => write_3mf(&mut out, parts)?,
    }
    let file = out.into_inner().map_err(|e| e.to_string())?;
    let r = file.sync_all();
    r.map_err(|e| e.to_string())
}

/// A position in single precision.
fn single(p: DVec3) -> [f32; 3] {
    p.as_vec3().to_array()
}

/// A triangle's unit normal, from its single-precision corners.
fn normal(corners: [[f32; 3]; 3]) -> [f32; 3] {
    let [a, b, c] = corners.map(glam::Vec3::from_array);
    (b - a).cross(c - a).normalize_or_zero().to_array()
}

fn write_stl(out: &mut impl Write, parts: &[Part]) -> std::io::Result<()> {
    // The crate writes one float at a time: the triangles are encoded by
    // it in chunks on every thread, and the chunks written in order.
    let count = parts.iter().map(|p| p.mesh.triangles.len()).sum();
    let chunks: Vec<(&Mesh, &[[u32; 3]])> = parts
        .iter()
        .flat_map(|part| {
            let mesh = part.mesh;
            mesh.triangles.chunks(STL_CHUNK).map(move |c| (mesh, c))
        })
        .collect();
    // The header (with the whole count, for an iterator that says it holds
    // `count` triangles and yields none), then each chunk past its own, a
    // few at a time into buffers used again: fresh pages for the whole file
    // cost more than the encoding.
    stl_io::write_stl(out, Counted(std::iter::empty::<stl_io::Triangle>(), count))?;
    let mut buffers = vec![Vec::new(); 2 * rayon::current_num_threads()];
    for group in chunks.chunks(buffers.len()) {
        buffers
            .par_iter_mut()
            .zip(group)
            .try_for_each(|(bytes, &(mesh, chunk))| {
                let triangles = chunk.iter().map(|t| {
                    let corners = t.map(|v| single(mesh.positions[v as usize]));
                    stl_io::Triangle {
                        normal: stl_io::Normal::new(normal(corners)),
                        vertices: corners.map(stl_io::Vertex::new),
                    }
                });
                bytes.clear();
                stl_io::write_stl(bytes, triangles)
            })?;
        for bytes in &buffers[..group.len()] {
            out.write_all(&bytes[STL_HEADER..])?;
        }
    }
    Ok(())
}

/// Triangles one task of the STL writer encodes.
const STL_CHUNK: usize = 1 << 14;

/// Bytes of a binary STL's header: 80 free, then the triangles' count.
const STL_HEADER: usize = 84;

/// An iterator that knows how many items it has left, for a writer that
/// must write the count first; built without gathering the items.
struct Counted<I>(I, usize);

impl<I: Iterator> Iterator for Counted<I> {
    type Item = I::Item;

    fn next(&mut self) -> Option<I::Item> {
        let item = self.0.next()?;
        self.1 -= 1;
        Some(item)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.1, Some(self.1))
    }
}

impl<I: Iterator> ExactSizeIterator for Counted<I> {}

/// Each part's first vertex in the parts' vertices laid end to end.
fn vertex_offsets(parts: &[Part]) -> Vec<usize> {
    parts
        .iter()
        .scan(0, |next, part| {
            let first = *next;
            *next += part.mesh.positions.len();
            Some(first)
        })
        .collect()
}

fn write_obj(out: &mut impl Write, parts: &[Part]) -> Result<(), obj::ObjError> {
    let objects = parts
        .iter()
        .zip(vertex_offsets(parts))
        .map(|(part, first)| {
            let mut group = obj::Group::new("surface".into());
            group.polys = part
                .mesh
                .triangles
                .iter()
                .map(|t| {
                    obj::SimplePolygon(
                        t.iter()
                            .map(|&v| obj::IndexTuple(first + v as usize, None, None))
                            .collect(),
                    )
                })
                .collect();
            let mut object = obj::Object::new(part.name.into());
            object.groups.push(group);
            object
        })
        .collect();
    let data = obj::ObjData {
        position: parts
            .iter()
            .flat_map(|part| part.mesh.positions.iter().map(|&p| single(p)))
            .collect(),
        objects,
        ..Default::default()
    };
    data.write_to_buf(out)
}

/// One element of a PLY file: a vertex or a face.
#[derive(Debug, Clone)]
enum PlyElement {
    Vertex([f64; 3]),
    Face([i32; 3]),
}

impl ply_rs_bw::ply::PropertyAccess for PlyElement {
    fn new() -> Self {
        PlyElement::Vertex([0.0; 3])
    }

    fn get_double(&self, name: &str) -> Option<f64> {
        match (self, name) {
            (PlyElement::Vertex(p), "x") => Some(p[0]),
            (PlyElement::Vertex(p), "y") => Some(p[1]),
            (PlyElement::Vertex(p), "z") => Some(p[2]),
            _ => None,
        }
    }

    fn get_list_int(&self, name: &str) -> Option<&[i32]> {
        match (self, name) {
            (PlyElement::Face(f), "vertex_indices") => Some(f),
            _ => None,
        }
    }
}

fn write_ply(out: &mut impl Write, parts: &[Part]) -> std::io::Result<()> {
    use ply_rs_bw::ply::{
        Addable, ElementDef, Encoding, Ply, PropertyDef, PropertyType, ScalarType,
    };
    let mut ply = Ply::<PlyElement>::new();
    ply.header.encoding = Encoding::BinaryLittleEndian;
    ply.header.comments.push("made by lgc".into());
    let vertices: Vec<PlyElement> = parts
        .iter()
        .flat_map(|part| part.mesh.positions.iter())
        .map(|p| PlyElement::Vertex(p.to_array()))
        .collect();
    let faces: Vec<PlyElement> = parts
        .iter()
        .zip(vertex_offsets(parts))
        .flat_map(|(part, first)| {
            part.mesh
                .triangles
                .iter()
                .map(move |t| PlyElement::Face(t.map(|v| (first + v as usize) as i32)))
        })
        .collect();
    let mut vertex = ElementDef::new("vertex".into());
    for axis in ["x", "y", "z"] {
        vertex.properties.add(PropertyDef::new(
            axis.into(),
            PropertyType::Scalar(ScalarType::Double),
        ));
    }
    vertex.count = vertices.len();
    ply.header.elements.add(vertex);
    let mut face = ElementDef::new("face".into());
    face.properties.add(PropertyDef::new(
        "vertex_indices".into(),
        PropertyType::List(ScalarType::UChar, ScalarType::Int),
    ));
    face.count = faces.len();
    ply.header.elements.add(face);
    ply.payload.insert("vertex".into(), vertices);
    ply.payload.insert("face".into(), faces);
    ply_rs_bw::writer::Writer::new()
        .write_ply_unchecked(out, &ply)
        .map(|_| ())
}

/// A glTF file being assembled: its JSON and its binary buffer.
struct GltfBuilder {
    root: gltf::json::Root,
    bin: Vec<u8>,
}

impl GltfBuilder {
    /// A view of the bytes `start..` of the buffer (the only buffer, index 0).
    fn view(
        &mut self,
        start: usize,
        target: gltf::json::buffer::Target,
    ) -> gltf::json::Index<gltf::json::buffer::View> {
        use gltf::json;
        use json::validation::{Checked::Valid, USize64};
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(self.bin.len() - start),
            byte_offset: Some(USize64::from(start)),
            byte_stride: None,
            extensions: Default::default(),
            extras: Default::default(),
            name: None,
            target: Some(Valid(target)),
        })
    }

    /// An accessor of a whole view.
    fn accessor(
        &mut self,
        view: gltf::json::Index<gltf::json::buffer::View>,
        count: usize,
        component: gltf::json::accessor::ComponentType,
        type_: gltf::json::accessor::Type,
        bounds: Option<([f32; 3], [f32; 3])>,
    ) -> gltf::json::Index<gltf::json::Accessor> {
        use gltf::json;
        use json::validation::{Checked::Valid, USize64};
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: Some(USize64(0)),
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: Default::default(),
            extras: Default::default(),
            type_: Valid(type_),
            min: bounds.map(|b| json::Value::from(b.0.to_vec())),
            max: bounds.map(|b| json::Value::from(b.1.to_vec())),
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    /// One part as a mesh of one primitive, with its material, under a
    /// node of its own.
    fn part(&mut self, part: &Part) -> gltf::json::Index<gltf::json::Node> {
        use gltf::json;
        use json::validation::Checked::Valid;
        let positions: Vec<[f32; 3]> = part.mesh.positions.iter().map(|&p| single(p)).collect();
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let start = self.bin.len();
        for c in positions.iter().flatten() {
            self.bin.extend_from_slice(&c.to_le_bytes());
        }
        let position_view = self.view(start, json::buffer::Target::ArrayBuffer);
        let start = self.bin.len();
        for v in part.mesh.triangles.iter().flatten() {
            self.bin.extend_from_slice(&v.to_le_bytes());
        }
        let index_view = self.view(start, json::buffer::Target::ElementArrayBuffer);
        let position_accessor = self.accessor(
            position_view,
            positions.len(),
            json::accessor::ComponentType::F32,
            json::accessor::Type::Vec3,
            (!positions.is_empty()).then_some((lo, hi)),
        );
        let index_accessor = self.accessor(
            index_view,
            3 * part.mesh.triangles.len(),
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
        );
        let material = part.color.map(|[r, g, b]| {
            self.root.push(json::Material {
                name: Some(part.name.into()),
                pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                    base_color_factor: json::material::PbrBaseColorFactor([r, g, b, 1.0]),
                    metallic_factor: json::material::StrengthFactor(0.0),
                    ..Default::default()
                },
                ..Default::default()
            })
        });
        let primitive = json::mesh::Primitive {
            attributes: [(Valid(json::mesh::Semantic::Positions), position_accessor)].into(),
            extensions: Default::default(),
            extras: Default::default(),
            indices: Some(index_accessor),
            material,
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        };
        let mesh = self.root.push(json::Mesh {
            extensions: Default::default(),
            extras: Default::default(),
            name: Some(part.name.into()),
            primitives: vec![primitive],
            weights: None,
        });
        self.root.push(json::Node {
            mesh: Some(mesh),
            name: Some(part.name.into()),
            ..Default::default()
        })
    }
}

fn write_glb(out: &mut impl Write, parts: &[Part]) -> Result<(), String> {
    use gltf::json;
    use json::validation::USize64;
    let mut builder = GltfBuilder {
        root: json::Root::default(),
        bin: Vec::new(),
    };
    let nodes: Vec<_> = parts.iter().map(|part| builder.part(part)).collect();
    let GltfBuilder { mut root, mut bin } = builder;
    // Each view starts on a multiple of 4, as glTF asks of f32 and u32
    // data: every part's data is a whole number of 4-byte values.
    root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        extensions: Default::default(),
        extras: Default::default(),
        name: None,
        uri: None,
    });
    let scene = root.push(json::Scene {
        extensions: Default::default(),
        extras: Default::default(),
        name: None,
        nodes,
    });
    root.scene = Some(scene);
    let json_text = json::serialize::to_vec(&root).map_err(|e| e.to_string())?;
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            // Computed by the writer.
            length: 0,
        },
        json: std::borrow::Cow::Owned(json_text),
        bin: Some(std::borrow::Cow::Owned(bin)),
    };
    glb.to_writer(out).map_err(|e| e.to_string())
}

fn write_3mf<W: Write + Seek>(out: &mut W, parts: &[Part]) -> Result<(), String> {
    use threemf::model::mesh::{Mesh as Mesh3mf, Triangle, Triangles, Vertex, Vertices};
    use threemf::model::{Build, Item, Model, Object, Resources};
    let object = |(id, part): (usize, &Part)| Object {
        id,
        name: Some(part.name.into()),
        mesh: Some(Mesh3mf {
            vertices: Vertices {
                vertex: part
                    .mesh
                    .positions
                    .iter()
                    .map(|p| Vertex {
                        x: p.x,
                        y: p.y,
                        z: p.z,
                    })
                    .collect(),
            },
            triangles: Triangles {
                triangle: part
                    .mesh
                    .triangles
                    .iter()
                    .map(|t| Triangle {
                        v1: t[0] as usize,
                        v2: t[1] as usize,
                        v3: t[2] as usize,
                    })
                    .collect(),
            },
        }),
        ..Default::default()
    };
    // Object ids start at 1, as 3MF's own examples do.
    let model = Model {
        resources: Resources {
            object: parts
                .iter()
                .enumerate()
                .map(|(i, p)| object((i + 1, p)))
                .collect(),
            basematerials: None,
        },
        build: Build {
            item: (1..=parts.len())
                .map(|objectid| Item {
                    objectid,
                    transform: None,
                    partnumber: None,
                })
                .collect(),
        },
        ..Default::default()
    };
    threemf::write(out, model).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Witness;

    /// A mesh of `n` triangles over scattered vertices (not a surface: the
    /// writer does not care).
    fn scattered(n: usize, shift: f64) -> Mesh {
        let v = n + 2;
        let positions: Vec<DVec3> = (0..v)
            .map(|i| {
                let t = i as f64;
                DVec3::new((0.37 * t).sin(), (0.11 * t).cos(), shift + 1e-3 * t)
            })
            .collect();
        Mesh {
            triangles: (0..n as u32)
                .map(|i| [i, i + 1, (i * 7 + 2) % v as u32])
                .collect(),
            witnesses: vec![Witness::Root; v],
            radii: vec![0.0; v],
            positions,
        }
    }

    /// Bytes of one triangle of a binary STL: the normal and three corners
    /// in f32, and a 16-bit attribute.
    const STL_TRIANGLE: usize = 50;

    #[test]
    fn an_stl_of_many_chunks_holds_every_triangle_in_order() {
        let meshes = [
            scattered(2 * STL_CHUNK + 123, 0.0),
            scattered(STL_CHUNK - 5, 2.0),
        ];
        let parts: Vec<Part> = meshes
            .iter()
            .map(|mesh| Part {
                name: "part",
                mesh,
                color: None,
            })
            .collect();
        let mut bytes = Vec::new();
        write_stl(&mut bytes, &parts).unwrap();
        let count: usize = meshes.iter().map(|m| m.triangles.len()).sum();
        assert_eq!(bytes.len(), STL_HEADER + STL_TRIANGLE * count);
        assert_eq!(bytes[80..84], (count as u32).to_le_bytes());
        let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        let mut at = STL_HEADER;
        for mesh in &meshes {
            for t in &mesh.triangles {
                let corners = t.map(|v| single(mesh.positions[v as usize]));
                let written: Vec<f32> = (0..12).map(|k| float(at + 4 * k)).collect();
                assert_eq!(written[..3], normal(corners));
                assert_eq!(written[3..], corners.concat());
                at += STL_TRIANGLE;
            }
        }
    }
}
