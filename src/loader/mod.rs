//! glTF 2.0 loading (.gltf with .bin or data: URIs, and .glb).
//!
//! The file is read with a size cap and parsed into gltf's JSON data model;
//! everything after that is done here with checked lookups, so no input can
//! panic the loader. Only what the chosen scene references is read.

mod accessor;
mod buffers;
mod glb;
mod images;
mod tangents;

use crate::camera::{Camera, Projection};
use crate::material::{AlphaMode, Axis, Material, MaterialTextures, Rays, TangentSource};
use crate::punctual::{PunctualKind, PunctualLight};
use crate::scene::{Scene, Triangle, VertexAttributes};
use accessor::{read_floats, read_indices, BinChunk, Buffers, FloatData};
use glam::{Mat3, Mat4, Quat, Vec2, Vec4};
use crate::Vec3;
use images::{ImageCache, TextureRef};
pub use images::decode as decode_image;
use gltf::json::accessor::Type;
use gltf::json::mesh::{Mode, Semantic};
use gltf::json::validation::Checked;
use gltf::json::Root;
use std::collections::HashMap;
use std::fs::File;
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

/// Largest scene file Glint reads.
pub const MAX_SCENE_BYTES: u64 = 2 << 30;

/// Extensions Glint renders (others a file uses are named in a warning).
const RENDERED: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_anisotropy",
    "KHR_lights_punctual",
];

/// Extensions Glint understands or can safely ignore when a file requires them.
const SUPPORTED_REQUIRED: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_anisotropy",
    "KHR_lights_punctual",
];

#[derive(Debug, thiserror::Error)]
#[error("{file}: {message}")]
pub struct LoadError {
    pub file: String,
    pub message: String,
}

/// The camera name that asks for a camera framing the scene's bounds.
pub const AUTO_CAMERA: &str = "auto";

#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Which of the file's scenes; default: the file's `scene`, else 0.
    pub scene_index: Option<usize>,
    /// A camera by node or camera name, or `AUTO_CAMERA`; default: the
    /// first perspective camera met walking the scene graph depth first.
    pub camera: Option<String>,
    /// Nodes whose meshes camera rays pass (`Material::hidden_from_camera`).
    pub hidden_from_camera: Vec<String>,
    /// Nodes whose meshes some rays after the camera's pass
    /// (`Material::hidden_from_rays`).
    pub hidden_from_rays: Vec<(String, Rays)>,
    /// Materials, by name, and their anisotropy's tangent
    /// (`Material::anisotropy_tangent`).
    pub anisotropy_tangents: Vec<(String, TangentSource)>,
}

/// What `inspect_file` found when it read everything in a file.
#[derive(Debug)]
pub struct Inspection {
    /// Triangles the default scene renders.
    pub triangles: usize,
    pub accessors: usize,
    pub cameras: usize,
    /// Why `glint render` could not pick a camera, if it could not.
    pub camera_problem: Option<String>,
    pub warnings: Vec<String>,
}

/// Read and check everything in a file, not only what one scene uses:
/// every node (in any scene or none), every mesh, every accessor and
/// buffer. A camera is not required. For robustness testing and
/// `glint inspect`.
pub fn inspect_file(path: &Path) -> Result<Inspection, LoadError> {
    let fail = |message: String| LoadError { file: path.display().to_string(), message };
    let file = SceneFile::open(path).map_err(fail)?;
    let root = parse_root(&file.json).map_err(fail)?;
    let mut b = Builder::new(&root, file.bin(), scene_dir(path));
    let triangles = b.walk_everything().map_err(fail)?;
    let camera_problem = b.pick_camera(None).err();
    Ok(Inspection {
        triangles,
        accessors: root.accessors.len(),
        cameras: b.cameras.len(),
        camera_problem,
        warnings: b.warnings(),
    })
}

/// A scene file opened for loading: its JSON read, a GLB's BIN chunk left
/// in the file to be read a bufferView at a time.
struct SceneFile {
    json: Vec<u8>,
    bin: Option<(Arc<File>, Range<u64>)>,
}

impl SceneFile {
    fn open(path: &Path) -> Result<SceneFile, String> {
        let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
        if !meta.is_file() {
            return Err("not a regular file".into());
        }
        let file = File::open(path).map_err(|e| e.to_string())?;
        let len = meta.len();
        let head = buffers::read_range(&file, 0, 4)?;
        if glb::is_glb(&head) {
            let layout = glb::layout(len, &mut |offset, n| buffers::read_range(&file, offset, n))?;
            let json_len = layout.json.end - layout.json.start;
            if json_len > MAX_SCENE_BYTES {
                return Err(format!("the GLB's JSON chunk is {json_len} bytes; Glint reads up to {MAX_SCENE_BYTES}"));
            }
            let json = buffers::read_range(&file, layout.json.start, json_len as usize)?;
            if (json.len() as u64) < json_len {
                return Err("the file ended inside its JSON chunk (was it changed while read?)".into());
            }
            return Ok(SceneFile { json, bin: layout.bin.map(|range| (Arc::new(file), range)) });
        }
        if len > MAX_SCENE_BYTES {
            return Err(format!("file is {len} bytes; Glint reads scene files up to {MAX_SCENE_BYTES}"));
        }
        Ok(SceneFile { json: buffers::read_range(&file, 0, len as usize)?, bin: None })
    }

    fn bin(&self) -> Option<BinChunk<'_>> {
        self.bin.as_ref().map(|(file, range)| BinChunk::File(file.clone(), range.clone()))
    }
}

fn scene_dir(path: &Path) -> Option<&Path> {
    path.parent().map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p })
}

fn parse_root(json: &[u8]) -> Result<Root, String> {
    let root: Root = serde_json::from_slice(json).map_err(|e| format!("not valid glTF JSON: {e}"))?;
    if !root.asset.version.starts_with("2.") {
        return Err(format!("glTF version '{}' is not supported (only 2.x)", root.asset.version));
    }
    if let Some(ext) = root.extensions_required.iter().find(|e| !SUPPORTED_REQUIRED.contains(&e.as_str())) {
        return Err(format!("requires extension {ext}, which Glint does not support"));
    }
    Ok(root)
}

pub fn load_file(path: &Path, options: &LoadOptions) -> Result<Scene, LoadError> {
    let fail = |message: String| LoadError { file: path.display().to_string(), message };
    let file = SceneFile::open(path).map_err(fail)?;
    load_parts(&file.json, file.bin(), scene_dir(path), options).map_err(fail)
}

/// Load from memory. `base_dir` is where relative URIs point (None: only
/// data: URIs and the GLB BIN chunk may be used); `name` is used in errors.
pub fn load_bytes(bytes: &[u8], base_dir: Option<&Path>, name: &str, options: &LoadOptions) -> Result<Scene, LoadError> {
    let fail = |message: String| LoadError { file: name.to_string(), message };
    if glb::is_glb(bytes) {
        let layout = glb::parse(bytes).map_err(fail)?;
        let range = |r: Range<u64>| &bytes[r.start as usize..r.end as usize];
        load_parts(range(layout.json), layout.bin.map(|b| BinChunk::Memory(range(b))), base_dir, options).map_err(fail)
    } else {
        load_parts(bytes, None, base_dir, options).map_err(fail)
    }
}

fn load_parts(json: &[u8], bin: Option<BinChunk>, base_dir: Option<&Path>, options: &LoadOptions) -> Result<Scene, String> {
    let root = parse_root(json)?;
    let mut builder = Builder::new(&root, bin, base_dir);
    for name in &options.hidden_from_camera {
        builder.hidden_nodes.entry(name.clone()).or_default().camera = true;
    }
    for (name, rays) in &options.hidden_from_rays {
        let hiding = builder.hidden_nodes.entry(name.clone()).or_default();
        hiding.rays = hiding.rays.union(*rays);
    }
    builder.anisotropy_tangents = options.anisotropy_tangents.clone();
    builder.walk_scene(options.scene_index)?;
    let camera = match options.camera.as_deref() {
        Some(AUTO_CAMERA) => {
            let (min, max) = crate::scene::bounds(&builder.triangles);
            Camera::framing(min, max)?
        }
        wanted => builder.pick_camera(wanted)?,
    };
    let warnings = builder.warnings();
    let mut scene = Scene::new(builder.triangles, builder.materials, camera);
    scene.punctual = builder.lights;
    scene.warnings = warnings;
    scene.attributes = builder.attributes;
    scene.default_material = builder.material_ids.get(&None).copied();
    scene.images = builder.images.images;
    scene.bytes_read = builder.buffers.bytes_read;
    Ok(scene)
}

#[derive(Default)]
struct Stats {
    skipped_modes: HashMap<String, usize>,
    non_finite: usize,
    degenerate: usize,
    bad_normals: usize,
    dangling_indices: usize,
    bad_lights: usize,
    /// Vertex attributes a material needs that a primitive does not have.
    missing_attributes: HashMap<String, usize>,
    /// Emitting materials on nodes hidden from diffuse, glossy or
    /// transmission rays (`Builder::hidden_material`).
    emitters_hidden_from_scattered: std::collections::BTreeSet<String>,
}

/// Vertex data a material's textures need.
#[derive(Clone, Copy, Debug, Default)]
struct Needs {
    uv: [bool; 2],
    /// The texture coordinate set of the normal map, when it has one.
    normal_map_set: Option<usize>,
}

struct CameraCandidate {
    node_name: Option<String>,
    camera: usize,
    world: Mat4,
}

/// What a node's meshes are hidden from (Blender's Ray Visibility).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
struct Hiding {
    camera: bool,
    rays: Rays,
}

struct Builder<'a> {
    root: &'a Root,
    buffers: Buffers<'a>,
    base_dir: Option<&'a Path>,
    triangles: Vec<Triangle>,
    attributes: VertexAttributes,
    materials: Vec<Material>,
    needs: Vec<Needs>,
    images: ImageCache,
    /// glTF material index (None: the default material) → ours.
    material_ids: HashMap<Option<usize>, u32>,
    /// Nodes hidden from some rays, and (ours, what from) → that copy.
    hidden_nodes: HashMap<String, Hiding>,
    hidden_ids: HashMap<(u32, Hiding), u32>,
    anisotropy_tangents: Vec<(String, TangentSource)>,
    cameras: Vec<CameraCandidate>,
    lights: Vec<PunctualLight>,
    stats: Stats,
}

fn local_transform(node: &gltf::json::scene::Node) -> Mat4 {
    if let Some(m) = node.matrix {
        return Mat4::from_cols_array(&m);
    }
    let t = node.translation.map_or(glam::Vec3::ZERO, glam::Vec3::from);
    let r = node.rotation.map_or(Quat::IDENTITY, |q| Quat::from_array(q.0));
    let s = node.scale.map_or(glam::Vec3::ONE, glam::Vec3::from);
    // The file's quaternion need not be exactly unit length.
    let r = if r.length_squared() > 0.0 && r.is_finite() { r.normalize() } else { r };
    Mat4::from_scale_rotation_translation(s, r, t)
}

impl<'a> Builder<'a> {
    fn new(root: &'a Root, bin: Option<BinChunk<'a>>, base_dir: Option<&'a Path>) -> Self {
        Builder {
            root,
            buffers: Buffers::new(root, bin, base_dir),
            base_dir,
            triangles: Vec::new(),
            attributes: VertexAttributes::default(),
            materials: Vec::new(),
            needs: Vec::new(),
            images: ImageCache::default(),
            material_ids: HashMap::new(),
            hidden_nodes: HashMap::new(),
            hidden_ids: HashMap::new(),
            anisotropy_tangents: Vec::new(),
            cameras: Vec::new(),
            lights: Vec::new(),
            stats: Stats::default(),
        }
    }

    fn walk_scene(&mut self, scene_index: Option<usize>) -> Result<(), String> {
        let root = self.root;
        if root.scenes.is_empty() {
            return Err("the file has no scenes to render".into());
        }
        let index = scene_index.or(root.scene.map(|s| s.value())).unwrap_or(0);
        let scene = root
            .scenes
            .get(index)
            .ok_or_else(|| format!("scene {index} does not exist (the file has {})", root.scenes.len()))?;
        let roots: Vec<usize> = scene.nodes.iter().map(|n| n.value()).collect();
        let mut seen = vec![false; root.nodes.len()];
        self.walk_nodes(&roots, &mut seen)
    }

    /// Every node of every scene (the default scene first), then every node
    /// no scene reaches (which finds cycles that hang off nothing), every
    /// mesh no node uses, every buffer and every accessor. Returns the
    /// number of triangles the default scene renders.
    fn walk_everything(&mut self) -> Result<usize, String> {
        let root = self.root;
        let default_triangles = if root.scenes.is_empty() {
            0
        } else {
            self.walk_scene(None)?;
            self.triangles.len()
        };
        let mut seen = vec![false; root.nodes.len()];
        for scene in &root.scenes {
            let roots: Vec<usize> = scene.nodes.iter().map(|n| n.value()).collect();
            // Scenes may share root nodes; each walk checks its own tree.
            seen.iter_mut().for_each(|s| *s = false);
            self.walk_nodes(&roots, &mut seen)?;
        }
        let mut child = vec![false; root.nodes.len()];
        for n in &root.nodes {
            for c in n.children.iter().flatten() {
                if let Some(flag) = child.get_mut(c.value()) {
                    *flag = true;
                }
            }
        }
        seen.iter_mut().for_each(|s| *s = false);
        let orphans: Vec<usize> = (0..root.nodes.len()).filter(|&i| !child[i]).collect();
        self.walk_nodes(&orphans, &mut seen)?;
        if let Some(unreached) = seen.iter().position(|s| !s) {
            return Err(format!("node {unreached} is part of a node cycle"));
        }
        for mesh in 0..root.meshes.len() {
            self.add_mesh(mesh, &Mat4::IDENTITY, Hiding::default())?;
        }
        for b in 0..root.buffers.len() {
            self.buffers.get(b)?;
        }
        for a in 0..root.accessors.len() {
            read_floats(&mut self.buffers, a, &[Type::Scalar, Type::Vec2, Type::Vec3, Type::Vec4, Type::Mat2, Type::Mat3, Type::Mat4])
                .map_err(|e| format!("accessor {a}: {e}"))?;
        }
        Ok(default_triangles)
    }

    fn walk_nodes(&mut self, roots: &[usize], seen: &mut [bool]) -> Result<(), String> {
        let root = self.root;
        // glTF node hierarchies are strict trees: a node met twice means a
        // cycle or a shared child, both invalid.
        let mut stack: Vec<(usize, Mat4)> = roots.iter().rev().map(|&n| (n, Mat4::IDENTITY)).collect();
        while let Some((index, parent)) = stack.pop() {
            let node = root.nodes.get(index).ok_or_else(|| format!("node {index} does not exist"))?;
            if std::mem::replace(&mut seen[index], true) {
                return Err(format!("node {index} is reached twice (a node cycle or a shared child)"));
            }
            let world = parent * local_transform(node);
            if let Some(mesh) = node.mesh {
                let hiding = node.name.as_ref().and_then(|n| self.hidden_nodes.get(n)).copied().unwrap_or_default();
                self.add_mesh(mesh.value(), &world, hiding)?;
            }
            if let Some(light) = node.extensions.as_ref().and_then(|e| e.khr_lights_punctual.as_ref()) {
                self.add_light(light.light.value(), node.name.as_deref(), &world);
            }
            if let Some(camera) = node.camera {
                self.cameras.push(CameraCandidate { node_name: node.name.clone(), camera: camera.value(), world });
            }
            for child in node.children.iter().flatten().rev() {
                stack.push((child.value(), world));
            }
        }
        Ok(())
    }

    /// A KHR_lights_punctual light at a node: it sits at the node's origin
    /// and shines down the node's −Z.
    fn add_light(&mut self, index: usize, node_name: Option<&str>, world: &Mat4) {
        use gltf::json::extensions::scene::khr_lights_punctual::Type;
        let light = self.root.extensions.as_ref().and_then(|e| e.khr_lights_punctual.as_ref()).and_then(|l| l.lights.get(index));
        let Some(light) = light else {
            self.stats.bad_lights += 1;
            return;
        };
        let kind = match (&light.type_, &light.spot) {
            (Checked::Valid(Type::Point), _) => PunctualKind::Point,
            (Checked::Valid(Type::Directional), _) => PunctualKind::Sun,
            (Checked::Valid(Type::Spot), Some(spot)) => PunctualLight::spot(spot.outer_cone_angle, spot.inner_cone_angle),
            // glTF's defaults: inner 0, outer π/4.
            (Checked::Valid(Type::Spot), None) => PunctualLight::spot(std::f32::consts::FRAC_PI_4, 0.0),
            _ => {
                self.stats.bad_lights += 1;
                return;
            }
        };
        let intensity = Vec3::from(light.color.map(|c| finite_or(c, 1.0).max(0.0))) * finite_or(light.intensity, 1.0).max(0.0);
        let position = Vec3::from_vec4(world.w_axis);
        let direction = (-Vec3::from_vec4(world.z_axis)).normalize_or_zero();
        if !position.is_finite() || direction == Vec3::ZERO || !intensity.is_finite() {
            self.stats.bad_lights += 1;
            return;
        }
        let name = light.name.clone().or(node_name.map(String::from)).unwrap_or_else(|| format!("light {index}"));
        self.lights.push(PunctualLight { name, kind, position, direction, intensity, size: 0.0, sphere: false, camera_sees: false, shadowless: false });
    }

    fn material_id(&mut self, index: Option<usize>) -> Result<u32, String> {
        if let Some(&id) = self.material_ids.get(&index) {
            return Ok(id);
        }
        let (material, needs) = match index {
            None => (Material::default(), Needs::default()),
            Some(i) => {
                let m = self.root.materials.get(i).ok_or_else(|| format!("material {i} does not exist"))?;
                let mut material = convert_material(m, i);
                if let Some((_, source)) = self.anisotropy_tangents.iter().find(|(name, _)| *name == material.name) {
                    material.anisotropy_tangent = *source;
                }
                let textures = self.material_textures(m).map_err(|e| format!("material {i}: {e}"))?;
                let needs = needs_of(&textures);
                material.textures = (textures != MaterialTextures::default()).then(|| Box::new(textures));
                (material, needs)
            }
        };
        let id = self.materials.len() as u32;
        self.materials.push(material);
        self.needs.push(needs);
        self.material_ids.insert(index, id);
        Ok(id)
    }

    /// A material's textures, each resolved to a decoded image.
    fn material_textures(&mut self, m: &gltf::json::Material) -> Result<MaterialTextures, String> {
        fn info(i: &gltf::json::texture::Info) -> TextureRef<'_> {
            TextureRef { index: i.index.value(), tex_coord: i.tex_coord, transform: i.extensions.as_ref().and_then(|e| e.texture_transform.as_ref()) }
        }
        let pbr = &m.pbr_metallic_roughness;
        let base_color = pbr.base_color_texture.as_ref().map(info);
        let metallic_roughness = pbr.metallic_roughness_texture.as_ref().map(info);
        let emissive = m.emissive_texture.as_ref().map(info);
        let transmission = m.extensions.as_ref().and_then(|e| e.transmission.as_ref()).and_then(|t| t.transmission_texture.as_ref()).map(info);
        let coat_weight_info: Option<gltf::json::texture::Info> = clearcoat_field(m, "clearcoatTexture");
        let coat_roughness_info: Option<gltf::json::texture::Info> = clearcoat_field(m, "clearcoatRoughnessTexture");
        let coat_normal_info: Option<gltf::json::material::NormalTexture> = clearcoat_field(m, "clearcoatNormalTexture");
        let coat_normal_transform = coat_normal_info.as_ref().and_then(|n| n.extensions.as_ref()).and_then(|e| e.others.get("KHR_texture_transform")).and_then(|v| serde_json::from_value(v.clone()).ok());
        // The normal texture's transform sits in its extension's free map.
        let normal_transform = m
            .normal_texture
            .as_ref()
            .and_then(|n| n.extensions.as_ref())
            .and_then(|e| e.others.get("KHR_texture_transform"))
            .and_then(|v| serde_json::from_value(v.clone()).ok());
        let normal = m.normal_texture.as_ref().map(|n| (TextureRef { index: n.index.value(), tex_coord: n.tex_coord, transform: normal_transform.as_ref() }, finite_or(n.scale, 1.0)));
        let mut slot = |r: Option<TextureRef>| -> Result<_, String> {
            match r {
                Some(r) => self.images.slot(self.root, &mut self.buffers, self.base_dir, &r),
                None => Ok(None),
            }
        };
        Ok(MaterialTextures {
            base_color: slot(base_color)?,
            metallic_roughness: slot(metallic_roughness)?,
            emissive: slot(emissive)?,
            transmission: slot(transmission)?,
            coat: slot(coat_weight_info.as_ref().map(info))?,
            coat_roughness: slot(coat_roughness_info.as_ref().map(info))?,
            coat_normal: match &coat_normal_info {
                Some(n) => slot(Some(TextureRef { index: n.index.value(), tex_coord: n.tex_coord, transform: coat_normal_transform.as_ref() }))?.map(|s| (s, finite_or(n.scale, 1.0))),
                None => None,
            },
            normal: match normal {
                Some((r, scale)) => slot(Some(r))?.map(|s| (s, scale)),
                None => None,
            },
        })
    }

    /// A vertex attribute of a primitive, if it has it, checked against
    /// the vertex count.
    fn attribute(&mut self, prim: &gltf::json::mesh::Primitive, semantic: Semantic, types: &[Type], vertices: usize) -> Result<Option<FloatData>, String> {
        let Some(index) = prim.attributes.get(&Checked::Valid(semantic.clone())) else { return Ok(None) };
        let data = read_floats(&mut self.buffers, index.value(), types)?;
        if data.count() != vertices {
            // glTF's own name: NORMAL, TEXCOORD_0, COLOR_0, TANGENT.
            return Err(format!("{} has {} elements, POSITION {vertices}", semantic.to_string(), data.count()));
        }
        Ok(Some(data))
    }

    /// A copy of material `id` hidden as `hiding` says, made once. An
    /// emitter stays seen by scattered rays, with a warning: Cycles leaves
    /// its light out of light samples for the lobes hidden from it too,
    /// which Glint's light sampling does not.
    fn hidden_material(&mut self, id: u32, hiding: Hiding) -> u32 {
        if hiding == Hiding::default() {
            return id;
        }
        if let Some(&hidden) = self.hidden_ids.get(&(id, hiding)) {
            return hidden;
        }
        let material = &self.materials[id as usize];
        let mut rays = hiding.rays;
        if material.is_emissive() && rays.meets(Rays::SCATTERED) {
            self.stats.emitters_hidden_from_scattered.insert(material.name.clone());
            rays = rays.without(Rays::SCATTERED);
        }
        let hidden = self.materials.len() as u32;
        self.materials.push(Material { hidden_from_camera: hiding.camera, hidden_from_rays: rays, ..material.clone() });
        self.needs.push(self.needs[id as usize]);
        self.hidden_ids.insert((id, hiding), hidden);
        hidden
    }

    /// A mesh's triangles at a node's transform, hidden from what
    /// `hiding` says.
    fn add_mesh(&mut self, mesh_index: usize, world: &Mat4, hiding: Hiding) -> Result<(), String> {
        let root = self.root;
        let mesh = root.meshes.get(mesh_index).ok_or_else(|| format!("mesh {mesh_index} does not exist"))?;
        let linear = Mat3::from_mat4(*world);
        let normal_matrix = linear.inverse().transpose();
        // A mirroring transform turns counter-clockwise into clockwise.
        let flip = linear.determinant() < 0.0;
        let radial = self.radial_tangents(mesh_index)?;
        // Object-space tangents of anisotropy turn into the world as
        // normals do, as Cycles' Tangent node turns them.
        let turned = |v: Vec3| {
            let w = normal_matrix * v;
            if w.is_finite() { w } else { Vec3::ZERO }
        };
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let what = |e: String| format!("mesh {mesh_index} primitive {pi}: {e}");
            match prim.mode {
                Checked::Valid(Mode::Triangles) => {}
                Checked::Valid(mode) => {
                    *self.stats.skipped_modes.entry(format!("{mode:?}")).or_default() += 1;
                    continue;
                }
                Checked::Invalid => return Err(what("invalid primitive mode".into())),
            }
            let pos_index = prim
                .attributes
                .get(&Checked::Valid(Semantic::Positions))
                .ok_or_else(|| what("has no POSITION attribute".into()))?;
            let positions = read_floats(&mut self.buffers, pos_index.value(), &[Type::Vec3]).map_err(what)?;
            let vertex_count = positions.count();
            let normals = self.attribute(prim, Semantic::Normals, &[Type::Vec3], vertex_count).map_err(what)?;
            let indices = match prim.indices {
                Some(i) => read_indices(&mut self.buffers, i.value()).map_err(what)?,
                None => (0..vertex_count as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(what(format!("index {bad} is out of range ({vertex_count} vertices)")));
            }
            self.stats.dangling_indices += indices.len() % 3;
            let material = self.material_id(prim.material.map(|m| m.value()))?;
            let material = self.hidden_material(material, hiding);
            let needs = self.needs[material as usize];
            let mut uvs: [Option<FloatData>; 2] = [None, None];
            for (set, semantic) in [Semantic::TexCoords(0), Semantic::TexCoords(1)].into_iter().enumerate() {
                if needs.uv[set] {
                    uvs[set] = self.attribute(prim, semantic, &[Type::Vec2], vertex_count).map_err(what)?;
                    if uvs[set].is_none() {
                        *self.stats.missing_attributes.entry(format!("TEXCOORD_{set}")).or_default() += 1;
                    }
                }
            }
            let colors = self.attribute(prim, Semantic::Colors(0), &[Type::Vec3, Type::Vec4], vertex_count).map_err(what)?;
            let whole = indices.len() / 3 * 3;
            // Per corner (index), in the file's winding.
            let tangents: Option<Vec<[f32; 4]>> = match needs.normal_map_set {
                None => None,
                Some(set) => match self.attribute(prim, Semantic::Tangents, &[Type::Vec4], vertex_count).map_err(what)? {
                    Some(t) => Some(indices[..whole].iter().map(|&i| t.get4(i as usize)).collect()),
                    None => uvs[set].as_ref().map(|uv| generated_tangents(&indices[..whole], &positions, normals.as_ref(), uv)),
                },
            };
            // An anisotropic material's tangents: per corner where a UV map
            // gives them (Cycles' Tangent node, UV Map), else radial.
            let m = &self.materials[material as usize];
            let (source, anisotropic) = (m.anisotropy_tangent, m.anisotropy > 0.0);
            let radial_axis = match source {
                TangentSource::Radial(axis) if anisotropic => radial.map(|r| (r, axis)),
                _ => None,
            };
            let uv_tangents: Option<Vec<[f32; 4]>> = match source {
                TangentSource::UvMap(set) if anisotropic => {
                    // Sets 0 and 1 are read (the request refuses others).
                    let set = (set as usize).min(1);
                    let uv = match uvs[set].take() {
                        Some(uv) => Some(uv),
                        None => self.attribute(prim, Semantic::TexCoords(set as u32), &[Type::Vec2], vertex_count).map_err(what)?,
                    };
                    let corners = uv.as_ref().map(|uv| generated_tangents(&indices[..whole], &positions, normals.as_ref(), uv));
                    uvs[set] = uv.filter(|_| needs.uv[set]);
                    Some(corners.unwrap_or_default())
                }
                _ => None,
            };
            let tangent_sign = if flip { -1.0 } else { 1.0 };
            for (k, tri) in indices.chunks_exact(3).enumerate() {
                let mut order = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
                let mut corners = [3 * k, 3 * k + 1, 3 * k + 2];
                if flip {
                    order.swap(1, 2);
                    corners.swap(1, 2);
                }
                let p = order.map(|i| world.transform_point3a(Vec3::from(positions.get3(i))));
                if !p.iter().all(|v| v.is_finite()) {
                    self.stats.non_finite += 1;
                    continue;
                }
                let cross = (p[1] - p[0]).cross(p[2] - p[0]);
                let len = cross.length();
                if !(len > 0.0 && len.is_finite()) {
                    self.stats.degenerate += 1;
                    continue;
                }
                let face = cross / len;
                let n = order.map(|i| {
                    let shading = normals.as_ref().map(|n| (normal_matrix * Vec3::from(n.get3(i))).normalize_or_zero());
                    match shading {
                        Some(v) if v != Vec3::ZERO && v.is_finite() => v,
                        Some(_) => {
                            self.stats.bad_normals += 1;
                            face
                        }
                        None => face,
                    }
                });
                self.triangles.push(Triangle::new(p, n, material));
                let before = self.triangles.len() - 1;
                let a = &mut self.attributes;
                for (column, uv) in a.uv.iter_mut().zip(&uvs) {
                    let corners = uv.as_ref().map(|uv| order.map(|i| Vec2::from(uv.get2(i))));
                    push_column(column, before, corners, [Vec2::ZERO; 3]);
                }
                let color = colors.as_ref().map(|c| order.map(|i| c.get4_or_one(i)));
                push_column(&mut a.color, before, color, [Vec4::ONE; 3]);
                let tangent = tangents.as_ref().map(|t| {
                    corners.map(|c| {
                        let [x, y, z, w] = t[c];
                        (linear * Vec3::new(x, y, z)).normalize_or_zero().extend(if w < 0.0 { -tangent_sign } else { tangent_sign })
                    })
                });
                push_column(&mut a.tangent, before, tangent, [Vec4::ZERO; 3]);
                let field = match (&uv_tangents, radial_axis) {
                    (Some(t), _) => Some(corners.map(|c| t.get(c).map_or(Vec3::ZERO, |&[x, y, z, _]| turned(Vec3::new(x, y, z))))),
                    (None, Some((r, axis))) => Some(order.map(|i| turned(r.at(Vec3::from(positions.get3(i)), axis)))),
                    (None, None) => None,
                };
                push_column(&mut a.anisotropy_tangent, before, field, [Vec3::ZERO; 3]);
            }
        }
        Ok(())
    }

    /// Cycles' default tangent field over a mesh (`RadialTangents`), where
    /// one of its primitives has an anisotropic material; None otherwise.
    fn radial_tangents(&mut self, mesh_index: usize) -> Result<Option<RadialTangents>, String> {
        let mesh = &self.root.meshes[mesh_index];
        let mut anisotropic = false;
        for prim in &mesh.primitives {
            let material = self.material_id(prim.material.map(|m| m.value()))?;
            anisotropic |= self.materials[material as usize].anisotropy > 0.0;
        }
        if !anisotropic {
            return Ok(None);
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for prim in &mesh.primitives {
            let Some(index) = prim.attributes.get(&Checked::Valid(Semantic::Positions)) else { continue };
            let Ok(positions) = read_floats(&mut self.buffers, index.value(), &[Type::Vec3]) else { continue };
            for i in 0..positions.count() {
                let p = Vec3::from(positions.get3(i));
                if p.is_finite() {
                    (lo, hi) = (lo.min(p), hi.max(p));
                }
            }
        }
        Ok((lo.cmple(hi).all()).then(|| RadialTangents::of_bounds(lo, hi)))
    }

    fn pick_camera(&self, wanted: Option<&str>) -> Result<Camera, String> {
        let root = self.root;
        let camera_name = |c: &CameraCandidate| root.cameras.get(c.camera).and_then(|cam| cam.name.clone());
        let candidate = match wanted {
            Some(name) => self
                .cameras
                .iter()
                .find(|c| c.node_name.as_deref() == Some(name) || camera_name(c).as_deref() == Some(name))
                .ok_or_else(|| format!("no camera named '{name}' in the scene"))?,
            None => self
                .cameras
                .iter()
                .find(|c| root.cameras.get(c.camera).is_some_and(|cam| cam.perspective.is_some() || cam.orthographic.is_some()))
                .ok_or("the scene has no camera (add one in Blender, or render with --camera auto)")?,
        };
        let cam = root.cameras.get(candidate.camera).ok_or_else(|| format!("camera {} does not exist", candidate.camera))?;
        let name = candidate.node_name.clone().or_else(|| cam.name.clone()).unwrap_or_else(|| format!("camera {}", candidate.camera));
        // A camera's type names the one of its two objects it uses; a file
        // whose type is missing or unknown still has at most one of them.
        let orthographic = match cam.type_ {
            Checked::Valid(gltf::json::camera::Type::Orthographic) => true,
            Checked::Valid(gltf::json::camera::Type::Perspective) => false,
            _ => cam.perspective.is_none(),
        };
        if orthographic {
            let o = cam.orthographic.as_ref().ok_or_else(|| format!("camera '{name}' is orthographic but has no orthographic object"))?;
            // glTF's xmag and ymag are half the view's width and height;
            // the image's aspect ratio shapes the view, as for a perspective
            // camera, so xmag picks only a default image height.
            let aspect = (o.xmag / o.ymag).abs();
            Camera::with_projection(name, &candidate.world, Projection::Orthographic { half_height: o.ymag }, Some(aspect), [o.znear, o.zfar])
        } else {
            let p = cam.perspective.as_ref().ok_or_else(|| format!("camera '{name}' is perspective but has no perspective object"))?;
            // No zfar: an infinite projection, which clips nothing far.
            Camera::with_projection(name, &candidate.world, Projection::Perspective { yfov: p.yfov }, p.aspect_ratio, [p.znear, p.zfar.unwrap_or(f32::INFINITY)])
        }
    }

    fn warnings(&self) -> Vec<String> {
        let s = &self.stats;
        let mut w = Vec::new();
        let mut modes: Vec<_> = s.skipped_modes.iter().collect();
        modes.sort();
        for (mode, n) in modes {
            w.push(format!("skipped {n} primitive(s) with mode {mode}: only triangles are rendered"));
        }
        if s.non_finite > 0 {
            w.push(format!("dropped {} triangle(s) with NaN or infinite positions", s.non_finite));
        }
        if s.degenerate > 0 {
            w.push(format!("dropped {} zero-area triangle(s)", s.degenerate));
        }
        if s.bad_normals > 0 {
            w.push(format!("{} vertex normal(s) were zero or non-finite; used the face normal", s.bad_normals));
        }
        if s.dangling_indices > 0 {
            w.push(format!("ignored {} trailing index(es) that do not form a whole triangle", s.dangling_indices));
        }
        if s.bad_lights > 0 {
            w.push(format!("left out {} punctual light(s) that do not exist, have an unknown type, or a non-finite transform or intensity", s.bad_lights));
        }
        for name in &s.emitters_hidden_from_scattered {
            w.push(format!("material '{name}' emits light on an object hidden from diffuse, glossy or transmission rays: those rays see it (Glint renders that Ray Visibility only on objects that do not emit)"));
        }
        let mut missing: Vec<_> = s.missing_attributes.iter().collect();
        missing.sort();
        for (attribute, n) in missing {
            w.push(format!("{n} primitive(s) have textured materials but no {attribute}: the texture's first texel is used"));
        }
        w.extend(self.images.failures.iter().cloned());
        if self.images.unsupported_sets > 0 {
            w.push(format!("{} texture reference(s) use a texture coordinate set above 1: TEXCOORD_1 is read instead", self.images.unsupported_sets));
        }
        let textured_anisotropy: Vec<String> = self
            .root
            .materials
            .iter()
            .enumerate()
            .filter(|(_, m)| anisotropy_extension(m).is_some_and(|e| e.get("anisotropyTexture").is_some()))
            .map(|(i, m)| m.name.clone().unwrap_or_else(|| format!("material {i}")))
            .collect();
        if !textured_anisotropy.is_empty() {
            w.push(format!("{}: the anisotropy texture is not read yet, only its strength and rotation factors", textured_anisotropy.join(", ")));
        }
        let unsupported: Vec<&str> = self.root.extensions_used.iter().map(String::as_str).filter(|e| !RENDERED.contains(e)).collect();
        if !unsupported.is_empty() {
            w.push(format!("not rendered yet, ignored: {}", unsupported.join(", ")));
        }
        w
    }
}

/// Append one triangle's corners to an attribute column: a column starts
/// (filled with `default` for the triangles before) when a triangle first
/// has the attribute, and once started, every triangle adds an entry.
fn push_column<T: Copy>(column: &mut Vec<T>, before: usize, value: Option<T>, default: T) {
    match value {
        Some(v) => {
            column.resize(before, default);
            column.push(v);
        }
        None if !column.is_empty() => column.push(default),
        None => {}
    }
}

/// The tangent Cycles gives a Principled BSDF whose Tangent input is not
/// linked (its Geometry node's Tangent): from the object's generated
/// coordinates g, which map its texture space — by default the mesh's
/// bounds, centre L and half-size S — to [0, 1]³, the vector
/// (−(g_y − ½), g_x − ½, 0) turned into world space as a normal is (by
/// the inverse transpose of the object's matrix), then set square to the
/// normal: circles about the object's Z axis. In glTF's Y-up local axes
/// (Blender's x, y, z are glTF's x, −z, y) that vector is
/// ((z − L_z)/(2 S_z), 0, −(x − L_x)/(2 S_x)). Being affine in the
/// position, its value at a hit is its corners' mixed by barycentrics.
#[derive(Clone, Copy, Debug)]
struct RadialTangents {
    centre: Vec3,
    half_size: Vec3,
}

impl RadialTangents {
    /// Blender's texture space of a mesh with these bounds
    /// (BKE_mesh_texspace_calc): an empty extent counts as 1, a tiny one
    /// as 1e-5.
    fn of_bounds(lo: Vec3, hi: Vec3) -> Self {
        let half = (hi - lo) * 0.5;
        let half_size = Vec3::from(half.to_array().map(|h| if h == 0.0 { 1.0 } else { h.max(1e-5) }));
        RadialTangents { centre: (lo + hi) * 0.5, half_size }
    }

    /// The (unnormalised) object-space field about `axis` at local
    /// position `p`, in glTF's axes. About Blender's Z it is the vector
    /// above; about X, Cycles' (0, −(g_z − ½), g_y − ½), which is (0, −d_z,
    /// d_y) in glTF's axes; about Y, (−(g_z − ½), 0, g_x − ½): (−d_y, d_x,
    /// 0) — d = (p − L)/(2S).
    fn at(&self, p: Vec3, axis: Axis) -> Vec3 {
        let d = (p - self.centre) / (2.0 * self.half_size);
        match axis {
            Axis::X => Vec3::new(0.0, -d.z, d.y),
            Axis::Y => Vec3::new(-d.y, d.x, 0.0),
            Axis::Z => Vec3::new(d.z, 0.0, -d.x),
        }
    }
}

/// What a material's textures read from its primitives.
fn needs_of(t: &MaterialTextures) -> Needs {
    let mut needs = Needs::default();
    for slot in [&t.base_color, &t.metallic_roughness, &t.emissive, &t.transmission, &t.coat, &t.coat_roughness].into_iter().flatten() {
        needs.uv[slot.texcoord as usize] = true;
    }
    // Tangents for one set: the base's normal map's, else the coat's.
    for (slot, _) in [&t.coat_normal, &t.normal].into_iter().flatten() {
        needs.uv[slot.texcoord as usize] = true;
        needs.normal_map_set = Some(slot.texcoord as usize);
    }
    needs
}

/// MikkTSpace tangents per corner for a primitive that has none. Without
/// normals (flat shading) each corner gets its face's normal.
fn generated_tangents(indices: &[u32], positions: &FloatData, normals: Option<&FloatData>, uv: &FloatData) -> Vec<[f32; 4]> {
    let corner_positions: Vec<[f32; 3]> = indices.iter().map(|&i| positions.get3(i as usize)).collect();
    let corner_normals: Vec<[f32; 3]> = match normals {
        Some(n) => indices.iter().map(|&i| n.get3(i as usize)).collect(),
        None => corner_positions
            .chunks_exact(3)
            .flat_map(|p| {
                let (a, b, c) = (Vec3::from(p[0]), Vec3::from(p[1]), Vec3::from(p[2]));
                [(b - a).cross(c - a).normalize_or_zero().to_array(); 3]
            })
            .collect(),
    };
    let corner_uvs: Vec<[f32; 2]> = indices.iter().map(|&i| uv.get2(i as usize)).collect();
    tangents::mikktspace(&corner_positions, &corner_normals, &corner_uvs)
}

pub(crate) fn finite_or(v: f32, default: f32) -> f32 {
    if v.is_finite() { v } else { default }
}

/// A glTF colour factor clamped to [0, 1], non-finite channels → `default`.
fn unit_colour(c: [f32; 3], default: f32) -> Vec3 {
    Vec3::from(c.map(|v| finite_or(v, default))).clamp(Vec3::ZERO, Vec3::ONE)
}

/// glTF pbrMetallicRoughness → Material. Factors are clamped to the ranges
/// glTF defines; emission is emissiveFactor × KHR_materials_emissive_strength,
/// read as radiance in W·sr⁻¹·m⁻² (Blender's Emission Strength 1 = radiance 1).
fn convert_material(m: &gltf::json::Material, index: usize) -> Material {
    let pbr = &m.pbr_metallic_roughness;
    let [r, g, b, alpha] = pbr.base_color_factor.0;
    let base_color = unit_colour([r, g, b], 1.0);
    let strength = m
        .extensions
        .as_ref()
        .and_then(|e| e.emissive_strength.as_ref())
        .map_or(1.0, |s| finite_or(s.emissive_strength.0, 1.0).max(0.0));
    let emissive = unit_colour(m.emissive_factor.0, 0.0);
    let specular = m
        .extensions
        .as_ref()
        .and_then(|e| e.specular.as_ref())
        .map_or(1.0, |s| finite_or(s.specular_factor.0, 1.0).clamp(0.0, 1.0));
    let extensions = m.extensions.as_ref();
    let specular_tint = extensions.and_then(|e| e.specular.as_ref()).map_or(Vec3::ONE, |s| unit_colour(s.specular_color_factor.0, 1.0));
    let transmission = extensions.and_then(|e| e.transmission.as_ref()).map_or(0.0, |t| finite_or(t.transmission_factor.0, 0.0).clamp(0.0, 1.0));
    // KHR_materials_ior allows 1 and up; anything else is its default.
    let ior = extensions.and_then(|e| e.ior.as_ref()).map(|i| i.ior.0).filter(|i| i.is_finite() && *i >= 1.0).unwrap_or(1.5);
    let absorption = extensions.and_then(|e| e.volume.as_ref()).map_or(Vec3::ZERO, volume_absorption);
    let (coat, coat_roughness) = clearcoat(clearcoat_extension(m));
    let (anisotropy, anisotropy_rotation) = anisotropy(m);
    let alpha_mode = match m.alpha_mode {
        Checked::Valid(gltf::json::material::AlphaMode::Mask) => AlphaMode::Mask(m.alpha_cutoff.map_or(0.5, |c| finite_or(c.0, 0.5))),
        Checked::Valid(gltf::json::material::AlphaMode::Blend) => AlphaMode::Blend,
        _ => AlphaMode::Opaque,
    };
    Material {
        name: m.name.clone().unwrap_or_else(|| format!("material {index}")),
        alpha: finite_or(alpha, 1.0).clamp(0.0, 1.0),
        alpha_mode,
        textures: None,
        specular,
        base_color,
        metallic: finite_or(pbr.metallic_factor.0, 1.0).clamp(0.0, 1.0),
        roughness: finite_or(pbr.roughness_factor.0, 1.0).clamp(0.0, 1.0),
        emission: emissive * strength,
        double_sided: m.double_sided,
        lamp: false,
        camera_sees_lamp: false,
        spread: None,
        multiscatter: true,
        transmission,
        translucent: false,
        ior,
        absorption,
        coat,
        coat_roughness,
        coat_tint: Vec3::ONE,
        specular_tint,
        anisotropy,
        anisotropy_rotation,
        // glTF carries no rough diffuse; a render request may (job.rs).
        diffuse_roughness: 0.0,
        anisotropy_tangent: TangentSource::default(),
        mix: None,
        shadowless: false,
        hidden_from_camera: false,
        hidden_from_rays: crate::material::Rays::NONE,
    }
}

/// KHR_materials_volume's absorption coefficient σ_a = −ln(c)/d per
/// metre (world space, as the extension gives d), for a material with a
/// volume (thicknessFactor > 0; 0 is thin-walled, no volume). A distance
/// that is not a positive number is the default, +∞ (no absorption);
/// a colour channel of 0 absorbs as one of 10⁻⁶, so that σ_a stays finite.
fn volume_absorption(v: &gltf::json::extensions::material::Volume) -> Vec3 {
    let distance = v.attenuation_distance.0;
    if !(finite_or(v.thickness_factor.0, 0.0) > 0.0 && distance > 0.0 && distance.is_finite()) {
        return Vec3::ZERO;
    }
    let colour = unit_colour(v.attenuation_color.0, 1.0).max(Vec3::splat(1e-6));
    Vec3::new(-colour.x.ln(), -colour.y.ln(), -colour.z.ln()) / distance
}

/// A material's KHR_materials_clearcoat, which gltf-json leaves as JSON.
fn clearcoat_extension(m: &gltf::json::Material) -> Option<&serde_json::Value> {
    m.extensions.as_ref().and_then(|e| e.others.get("KHR_materials_clearcoat"))
}

/// A texture info of a material's KHR_materials_clearcoat, which gltf-json
/// leaves as JSON; a malformed one is none.
fn clearcoat_field<T: serde::de::DeserializeOwned>(m: &gltf::json::Material, key: &str) -> Option<T> {
    clearcoat_extension(m).and_then(|c| c.get(key)).and_then(|v| serde_json::from_value(v.clone()).ok())
}

/// KHR_materials_clearcoat's factors (weight, roughness), each 0 where
/// absent or not a number, clamped to [0, 1]; its weight and roughness
/// textures scale them, and its normal texture bends the coat
/// (`material_textures`).
fn clearcoat(extension: Option<&serde_json::Value>) -> (f32, f32) {
    let factor = |name: &str| extension.and_then(|e| e.get(name)).and_then(serde_json::Value::as_f64).map_or(0.0, |v| finite_or(v as f32, 0.0).clamp(0.0, 1.0));
    (factor("clearcoatFactor"), factor("clearcoatRoughnessFactor"))
}

/// A material's KHR_materials_anisotropy, which gltf-json leaves as JSON.
fn anisotropy_extension(m: &gltf::json::Material) -> Option<&serde_json::Value> {
    m.extensions.as_ref().and_then(|e| e.others.get("KHR_materials_anisotropy"))
}

/// KHR_materials_anisotropy's strength, clamped to [0, 1], and its
/// rotation in turns (radians / 2π, as Blender's importer divides it), each
/// 0 where absent or not a finite number.
fn anisotropy(m: &gltf::json::Material) -> (f32, f32) {
    let extension = anisotropy_extension(m);
    let number = |name: &str| extension.and_then(|e| e.get(name)).and_then(serde_json::Value::as_f64).map_or(0.0, |v| finite_or(v as f32, 0.0));
    (number("anisotropyStrength").clamp(0.0, 1.0), number("anisotropyRotation") / std::f32::consts::TAU)
}

#[cfg(test)]
mod tests;
