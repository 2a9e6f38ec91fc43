//! glTF 2.0 loading (.gltf with .bin or data: URIs, and .glb).
//!
//! The file is read with a size cap and parsed into gltf's JSON data model;
//! everything after that is done here with checked lookups, so no input can
//! panic the loader. Only what the chosen scene references is read.

mod accessor;
mod buffers;
mod glb;

use crate::camera::Camera;
use crate::material::Material;
use crate::punctual::{PunctualKind, PunctualLight};
use crate::scene::{Scene, Triangle};
use accessor::{read_floats, read_indices, BinChunk, Buffers};
use glam::{Mat3, Mat4, Quat, Vec3};
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

/// Extensions Glint understands or can safely ignore when a file requires them.
const SUPPORTED_REQUIRED: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_lights_punctual",
];

#[derive(Debug, thiserror::Error)]
#[error("{file}: {message}")]
pub struct LoadError {
    pub file: String,
    pub message: String,
}

#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Which of the file's scenes; default: the file's `scene`, else 0.
    pub scene_index: Option<usize>,
    /// A camera by node or camera name; default: the first perspective
    /// camera met walking the scene graph depth first.
    pub camera: Option<String>,
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
    builder.walk_scene(options.scene_index)?;
    let camera = builder.pick_camera(options.camera.as_deref())?;
    let warnings = builder.warnings();
    let mut scene = Scene::new(builder.triangles, builder.materials, camera);
    scene.punctual = builder.lights;
    scene.warnings = warnings;
    scene.textured_materials = builder.stats.textured_materials;
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
    textured_materials: usize,
    bad_lights: usize,
}

struct CameraCandidate {
    node_name: Option<String>,
    camera: usize,
    world: Mat4,
}

struct Builder<'a> {
    root: &'a Root,
    buffers: Buffers<'a>,
    triangles: Vec<Triangle>,
    materials: Vec<Material>,
    /// glTF material index (None: the default material) → ours.
    material_ids: HashMap<Option<usize>, u32>,
    cameras: Vec<CameraCandidate>,
    lights: Vec<PunctualLight>,
    stats: Stats,
}

fn local_transform(node: &gltf::json::scene::Node) -> Mat4 {
    if let Some(m) = node.matrix {
        return Mat4::from_cols_array(&m);
    }
    let t = node.translation.map_or(Vec3::ZERO, Vec3::from);
    let r = node.rotation.map_or(Quat::IDENTITY, |q| Quat::from_array(q.0));
    let s = node.scale.map_or(Vec3::ONE, Vec3::from);
    // The file's quaternion need not be exactly unit length.
    let r = if r.length_squared() > 0.0 && r.is_finite() { r.normalize() } else { r };
    Mat4::from_scale_rotation_translation(s, r, t)
}

impl<'a> Builder<'a> {
    fn new(root: &'a Root, bin: Option<BinChunk<'a>>, base_dir: Option<&'a Path>) -> Self {
        Builder {
            root,
            buffers: Buffers::new(root, bin, base_dir),
            triangles: Vec::new(),
            materials: Vec::new(),
            material_ids: HashMap::new(),
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
            self.add_mesh(mesh, &Mat4::IDENTITY)?;
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
                self.add_mesh(mesh.value(), &world)?;
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
        let position = world.w_axis.truncate();
        let direction = (-world.z_axis.truncate()).normalize_or_zero();
        if !position.is_finite() || direction == Vec3::ZERO || !intensity.is_finite() {
            self.stats.bad_lights += 1;
            return;
        }
        let name = light.name.clone().or(node_name.map(String::from)).unwrap_or_else(|| format!("light {index}"));
        self.lights.push(PunctualLight { name, kind, position, direction, intensity });
    }

    fn material_id(&mut self, index: Option<usize>) -> Result<u32, String> {
        if let Some(&id) = self.material_ids.get(&index) {
            return Ok(id);
        }
        let material = match index {
            None => Material::default(),
            Some(i) => {
                let m = self.root.materials.get(i).ok_or_else(|| format!("material {i} does not exist"))?;
                if m.pbr_metallic_roughness.base_color_texture.is_some()
                    || m.pbr_metallic_roughness.metallic_roughness_texture.is_some()
                    || m.emissive_texture.is_some()
                    || m.normal_texture.is_some()
                {
                    self.stats.textured_materials += 1;
                }
                convert_material(m, i)
            }
        };
        let id = self.materials.len() as u32;
        self.materials.push(material);
        self.material_ids.insert(index, id);
        Ok(id)
    }

    fn add_mesh(&mut self, mesh_index: usize, world: &Mat4) -> Result<(), String> {
        let root = self.root;
        let mesh = root.meshes.get(mesh_index).ok_or_else(|| format!("mesh {mesh_index} does not exist"))?;
        let linear = Mat3::from_mat4(*world);
        let normal_matrix = linear.inverse().transpose();
        // A mirroring transform turns counter-clockwise into clockwise.
        let flip = linear.determinant() < 0.0;
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
            let normals = match prim.attributes.get(&Checked::Valid(Semantic::Normals)) {
                Some(n) => {
                    let n = read_floats(&mut self.buffers, n.value(), &[Type::Vec3]).map_err(what)?;
                    if n.count() != positions.count() {
                        return Err(what(format!("NORMAL has {} elements, POSITION {}", n.count(), positions.count())));
                    }
                    Some(n)
                }
                None => None,
            };
            let vertex_count = positions.count();
            let indices = match prim.indices {
                Some(i) => read_indices(&mut self.buffers, i.value()).map_err(what)?,
                None => (0..vertex_count as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(what(format!("index {bad} is out of range ({vertex_count} vertices)")));
            }
            self.stats.dangling_indices += indices.len() % 3;
            let material = self.material_id(prim.material.map(|m| m.value()))?;
            for tri in indices.chunks_exact(3) {
                let mut order = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
                if flip {
                    order.swap(1, 2);
                }
                let p = order.map(|i| world.transform_point3(Vec3::from(positions.get3(i))));
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
                self.triangles.push(Triangle { p, n, material });
            }
        }
        Ok(())
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
                .find(|c| root.cameras.get(c.camera).is_some_and(|cam| cam.perspective.is_some()))
                .ok_or("the scene has no perspective camera (add one in Blender, or name one with --camera)")?,
        };
        let cam = root.cameras.get(candidate.camera).ok_or_else(|| format!("camera {} does not exist", candidate.camera))?;
        let name = candidate.node_name.clone().or_else(|| cam.name.clone()).unwrap_or_else(|| format!("camera {}", candidate.camera));
        let p = cam
            .perspective
            .as_ref()
            .ok_or_else(|| format!("camera '{name}' is not a perspective camera (orthographic cameras are not supported)"))?;
        Camera::from_world(name, &candidate.world, p.yfov, p.aspect_ratio)
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
        if s.textured_materials > 0 {
            w.push(format!("{} material(s) use textures, which are not supported yet: their factors are used", s.textured_materials));
        }
        w
    }
}

fn finite_or(v: f32, default: f32) -> f32 {
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
    let [r, g, b, _alpha] = pbr.base_color_factor.0;
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
    Material {
        name: m.name.clone().unwrap_or_else(|| format!("material {index}")),
        specular,
        base_color,
        metallic: finite_or(pbr.metallic_factor.0, 1.0).clamp(0.0, 1.0),
        roughness: finite_or(pbr.roughness_factor.0, 1.0).clamp(0.0, 1.0),
        emission: emissive * strength,
        double_sided: m.double_sided,
        lamp: false,
        multiscatter: true,
    }
}

#[cfg(test)]
mod tests;
