//! Mesh files, the format chosen by the extension, each written by its own
//! crate into a temporary file beside the target and renamed into place, so
//! a failed write never leaves a half-written file.

use super::Mesh;
use crate::file::PendingFile;
use glam::DVec3;
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

    /// Writes the mesh into the temporary file and renames it into place.
    pub fn finish(self, mesh: &Mesh) -> Result<(), WriteError> {
        write_file(self.file.temp(), self.format, mesh).map_err(|e| self.file.encode_error(e))?;
        self.file.rename()
    }
}

/// Writes `mesh` to `path` in `format`.
fn write_file(path: &Path, format: MeshFormat, mesh: &Mesh) -> Result<(), String> {
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let mut out = BufWriter::new(file);
    match format {
        MeshFormat::Stl => write_stl(&mut out, mesh).map_err(|e| e.to_string())?,
        MeshFormat::Obj => write_obj(&mut out, mesh).map_err(|e| e.to_string())?,
        MeshFormat::Ply => write_ply(&mut out, mesh).map_err(|e| e.to_string())?,
        MeshFormat::Glb => write_glb(&mut out, mesh)?,
        MeshFormat::ThreeMf => write_3mf(&mut out, mesh)?,
    }
    let file = out.into_inner().map_err(|e| e.to_string())?;
    file.sync_all().map_err(|e| e.to_string())
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

fn write_stl(out: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    let triangles = mesh.triangles.iter().map(|t| {
        let corners = t.map(|v| single(mesh.positions[v as usize]));
        stl_io::Triangle {
            normal: stl_io::Normal::new(normal(corners)),
            vertices: corners.map(stl_io::Vertex::new),
        }
    });
    stl_io::write_stl(out, triangles)
}

fn write_obj(out: &mut impl Write, mesh: &Mesh) -> Result<(), obj::ObjError> {
    let polys = mesh
        .triangles
        .iter()
        .map(|t| {
            obj::SimplePolygon(
                t.iter()
                    .map(|&v| obj::IndexTuple(v as usize, None, None))
                    .collect(),
            )
        })
        .collect();
    let mut group = obj::Group::new("surface".into());
    group.polys = polys;
    let mut object = obj::Object::new("lgc".into());
    object.groups.push(group);
    let data = obj::ObjData {
        position: mesh.positions.iter().map(|&p| single(p)).collect(),
        objects: vec![object],
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

fn write_ply(out: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    use ply_rs_bw::ply::{
        Addable, ElementDef, Encoding, Ply, PropertyDef, PropertyType, ScalarType,
    };
    let mut ply = Ply::<PlyElement>::new();
    ply.header.encoding = Encoding::BinaryLittleEndian;
    ply.header.comments.push("made by lgc".into());
    let mut vertex = ElementDef::new("vertex".into());
    for axis in ["x", "y", "z"] {
        vertex.properties.add(PropertyDef::new(
            axis.into(),
            PropertyType::Scalar(ScalarType::Double),
        ));
    }
    vertex.count = mesh.positions.len();
    ply.header.elements.add(vertex);
    let mut face = ElementDef::new("face".into());
    face.properties.add(PropertyDef::new(
        "vertex_indices".into(),
        PropertyType::List(ScalarType::UChar, ScalarType::Int),
    ));
    face.count = mesh.triangles.len();
    ply.header.elements.add(face);
    ply.payload.insert(
        "vertex".into(),
        mesh.positions
            .iter()
            .map(|p| PlyElement::Vertex(p.to_array()))
            .collect(),
    );
    ply.payload.insert(
        "face".into(),
        mesh.triangles
            .iter()
            .map(|t| PlyElement::Face(t.map(|v| v as i32)))
            .collect(),
    );
    ply_rs_bw::writer::Writer::new()
        .write_ply_unchecked(out, &ply)
        .map(|_| ())
}

fn write_glb(out: &mut impl Write, mesh: &Mesh) -> Result<(), String> {
    use gltf::json;
    use json::validation::{Checked::Valid, USize64};
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|&p| single(p)).collect();
    let mut bin: Vec<u8> = Vec::with_capacity(12 * positions.len() + 12 * mesh.triangles.len());
    for p in &positions {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let index_offset = bin.len();
    for t in &mesh.triangles {
        for v in t {
            bin.extend_from_slice(&v.to_le_bytes());
        }
    }
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let mut root = json::Root::default();
    let buffer = root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        extensions: Default::default(),
        extras: Default::default(),
        name: None,
        uri: None,
    });
    let view = |root: &mut json::Root, offset: usize, length: usize, target| {
        root.push(json::buffer::View {
            buffer,
            byte_length: USize64::from(length),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            extensions: Default::default(),
            extras: Default::default(),
            name: None,
            target: Some(Valid(target)),
        })
    };
    let position_view = view(
        &mut root,
        0,
        index_offset,
        json::buffer::Target::ArrayBuffer,
    );
    let index_view = view(
        &mut root,
        index_offset,
        bin.len() - index_offset,
        json::buffer::Target::ElementArrayBuffer,
    );
    let accessor = |root: &mut json::Root,
                    view,
                    count: usize,
                    component,
                    type_,
                    bounds: Option<([f32; 3], [f32; 3])>| {
        root.push(json::Accessor {
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
    };
    let position_accessor = accessor(
        &mut root,
        position_view,
        positions.len(),
        json::accessor::ComponentType::F32,
        json::accessor::Type::Vec3,
        (!positions.is_empty()).then_some((lo, hi)),
    );
    let index_accessor = accessor(
        &mut root,
        index_view,
        3 * mesh.triangles.len(),
        json::accessor::ComponentType::U32,
        json::accessor::Type::Scalar,
        None,
    );
    let primitive = json::mesh::Primitive {
        attributes: [(Valid(json::mesh::Semantic::Positions), position_accessor)].into(),
        extensions: Default::default(),
        extras: Default::default(),
        indices: Some(index_accessor),
        material: None,
        mode: Valid(json::mesh::Mode::Triangles),
        targets: None,
    };
    let mesh_index = root.push(json::Mesh {
        extensions: Default::default(),
        extras: Default::default(),
        name: Some("surface".into()),
        primitives: vec![primitive],
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh_index),
        name: Some("surface".into()),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: Default::default(),
        extras: Default::default(),
        name: None,
        nodes: vec![node],
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

fn write_3mf<W: Write + Seek>(out: &mut W, mesh: &Mesh) -> Result<(), String> {
    use threemf::model::mesh::{Mesh as Mesh3mf, Triangle, Triangles, Vertex, Vertices};
    let model = Mesh3mf {
        vertices: Vertices {
            vertex: mesh
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
            triangle: mesh
                .triangles
                .iter()
                .map(|t| Triangle {
                    v1: t[0] as usize,
                    v2: t[1] as usize,
                    v3: t[2] as usize,
                })
                .collect(),
        },
    };
    threemf::write(out, model).map_err(|e| e.to_string())
}
