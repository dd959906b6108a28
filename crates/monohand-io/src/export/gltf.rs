//! glTF: an animated glTF 2.0 binary (`.glb`) of the 3D joints and bones, or of a
//! skinned hand mesh.

use crate::error::{name_of, IoError, IoResult};
use crate::hand_mesh::{HandMesh, JointPose, MESH_CREDIT, MESH_JOINTS};
use crate::jsonl::{FrameRecord, HandRecord};
use crate::sink::write_file_atomically;
use monohand_core::hand_model::{HandSide, BONES, JOINT_NAMES, NUM_JOINTS};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// Radius of the joint octahedra, metres.
const JOINT_RADIUS_M: f32 = 0.005;
/// Half-width of the bone pyramids, metres.
const BONE_HALF_WIDTH_M: f32 = 0.004;
/// Where along the bone the pyramid is widest (fraction of its length).
const BONE_WAIST: f32 = 0.2;

/// From the camera frame (mm, x right, y down, z forward) to glTF (m, x right,
/// y up, z toward the viewer): `(x, -y, -z) / 1000`. The skinned hand's poses
/// ([`crate::hand_mesh::HandMesh::pose`]) take joints in this frame.
pub fn to_gltf(p: [f64; 3]) -> [f32; 3] {
    [
        (p[0] / 1000.0) as f32,
        (-p[1] / 1000.0) as f32,
        (-p[2] / 1000.0) as f32,
    ]
}

/// The unit quaternion `[x, y, z, w]` turning +Y onto the unit vector `d`.
fn rotation_from_y(d: [f32; 3]) -> [f32; 4] {
    let w = 1.0 + d[1];
    if w < 1e-6 {
        return [1.0, 0.0, 0.0, 0.0]; // half turn about x
    }
    // cross((0, 1, 0), d) = (d.z, 0, -d.x)
    let q = [d[2], 0.0, -d[0], w];
    let n = q.iter().map(|v| v * v).sum::<f32>().sqrt();
    q.map(|v| v / n)
}

/// An octahedron-like solid: centre `c`, tips at `c +- (ax, ay, az)` on each
/// axis given as `(minus, plus)` per axis. Returns 6 positions and 8 outward triangles.
fn double_pyramid(x: (f32, f32), y: (f32, f32), z: (f32, f32), c: [f32; 3]) -> Vec<[f32; 3]> {
    vec![
        [c[0] + x.1, c[1], c[2]],
        [c[0] - x.0, c[1], c[2]],
        [c[0], c[1] + y.1, c[2]],
        [c[0], c[1] - y.0, c[2]],
        [c[0], c[1], c[2] + z.1],
        [c[0], c[1], c[2] - z.0],
    ]
}

/// The triangles of [`double_pyramid`], counter-clockwise seen from outside.
fn double_pyramid_indices() -> Vec<u16> {
    let mut idx = Vec::new();
    for sx in [0u16, 1] {
        for sy in [0u16, 1] {
            for sz in [0u16, 1] {
                let t = [sx, 2 + sy, 4 + sz];
                // Vertex 0/2/4 are the + tips; an odd number of - tips flips the winding.
                if (sx + sy + sz) % 2 == 0 {
                    idx.extend(t);
                } else {
                    idx.extend([t[0], t[2], t[1]]);
                }
            }
        }
    }
    idx
}

/// The track of one hand: its 3D joints (glTF coordinates) per frame from the frame it
/// first appeared in to the last it was seen in, `None` where it was absent between.
#[derive(Debug, Clone)]
struct Track {
    side: HandSide,
    id: Option<u64>,
    /// The frame of `samples[0]`.
    start: usize,
    samples: Vec<Option<[[f32; 3]; NUM_JOINTS]>>,
}

impl Track {
    /// The frames its keys are at, `first..=last` (its life, with one hidden frame before
    /// and after where those exist), and the samples over them.
    fn keyed(&self, frames: usize) -> (usize, Vec<Option<[[f32; 3]; NUM_JOINTS]>>) {
        let first = self.start.saturating_sub(1);
        let end = self.start + self.samples.len();
        let mut keyed = Vec::with_capacity(self.samples.len() + 2);
        if first < self.start {
            keyed.push(None);
        }
        keyed.extend_from_slice(&self.samples);
        if end < frames {
            keyed.push(None);
        }
        (first, keyed)
    }
}

/// Accumulates the 3D joints of every frame and writes an animated glTF 2.0
/// binary (`.glb`) on [`GltfWriter::finish`].
///
/// Each hand track (a hand `id`, or the side for hands without one) becomes a
/// node `hand_{id}_{side}` with 21 joint nodes (small octahedra, named after
/// [`JOINT_NAMES`]) and 20 bone nodes (tapered pyramids, coloured per finger)
/// whose translation, rotation and scale are animated at the frame timestamps
/// (linear interpolation; visibility uses step interpolation of the scale:
/// a hand absent from a frame is scaled to 0). A track is keyed over its own life
/// only (from the frame before it appears to the frame after it was last seen), so
/// hands that come and go cost what they are seen for. Coordinates are glTF's:
/// metres, x right, y up, z toward the viewer, i.e. the camera frame's
/// `(x, -y, -z) / 1000`; a glTF camera at the origin looks along -z, so it
/// sees the scene as the real camera did.
///
/// Memory: 21 x 3 floats per hand per frame it lives (256 bytes: 27.6 MB per hand
/// per hour at 30 fps), held until [`GltfWriter::finish`], which builds the whole
/// file in memory. The file is written to `PATH.tmp` and renamed, so it is either
/// complete or absent.
/// Nothing is written unless `finish` is called.
#[derive(Debug, Clone)]
pub struct GltfWriter {
    path: PathBuf,
    times: Vec<f64>,
    tracks: Vec<Track>,
    yfov_rad: f64,
    aspect: Option<f64>,
    /// The skinned meshes (left, right), when hands are drawn as [`GltfHand::Skinned`].
    meshes: Option<Box<[HandMesh; 2]>>,
}

/// How [`GltfWriter`] draws each hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GltfHand {
    /// 21 joint octahedra and 20 bone pyramids (the default of the library).
    #[default]
    Joints,
    /// A real hand mesh (the WebXR generic hand, [`crate::hand_mesh`]) skinned to the
    /// fitted joints.
    Skinned,
}

/// Key of a track in a frame.
fn track_key(h: &HandRecord) -> (Option<u64>, HandSide) {
    (h.id, h.side)
}

impl GltfWriter {
    /// A writer for `path` (nothing is written until [`GltfWriter::finish`]).
    pub fn new(path: impl AsRef<Path>) -> GltfWriter {
        GltfWriter {
            path: path.as_ref().to_path_buf(),
            times: Vec::new(),
            tracks: Vec::new(),
            yfov_rad: 0.8,
            aspect: None,
            meshes: None,
        }
    }

    /// Chooses how hands are drawn (default [`GltfHand::Joints`]); loads the skinned
    /// meshes, which are built into the library.
    pub fn set_hand(&mut self, hand: GltfHand) -> IoResult<()> {
        self.meshes = match hand {
            GltfHand::Joints => None,
            GltfHand::Skinned => Some(Box::new([
                HandMesh::webxr(HandSide::Left)?,
                HandMesh::webxr(HandSide::Right)?,
            ])),
        };
        Ok(())
    }

    /// Sets the field of view of the scene's camera to the real camera's:
    /// `yfov = 2 atan(height / (2 fy))`, `aspect = width / height`.
    pub fn set_camera(&mut self, yfov_rad: f64, aspect: f64) {
        if yfov_rad.is_finite() && yfov_rad > 0.0 && yfov_rad < std::f64::consts::PI {
            self.yfov_rad = yfov_rad;
        }
        self.aspect = (aspect.is_finite() && aspect > 0.0).then_some(aspect);
    }

    /// Sets the scene camera's field of view from a calibrated camera
    /// (see [`GltfWriter::set_camera`]).
    pub fn set_camera_from(&mut self, camera: &monohand_core::camera::Camera) {
        let k = &camera.intrinsics;
        if k.height > 0 && k.fy > 0.0 {
            let yfov = 2.0 * (k.height as f64 / (2.0 * k.fy)).atan();
            self.set_camera(yfov, k.width as f64 / k.height as f64);
        }
    }

    /// Frames added so far.
    pub fn frames(&self) -> usize {
        self.times.len()
    }

    /// Adds a frame at time `t_s` (seconds; must increase from frame to frame).
    /// Hands without `joints_3d_mm` count as absent; of two hands with the same
    /// track key (id and side) only the first is used.
    pub fn add_frame(&mut self, t_s: f64, hands: &[HandRecord]) -> IoResult<()> {
        let name = name_of(&self.path);
        // Compared as stored (f32): glTF needs strictly increasing key times.
        if !t_s.is_finite()
            || self
                .times
                .last()
                .is_some_and(|&last| t_s as f32 <= last as f32)
        {
            return Err(IoError::field(
                name,
                format!("frame {}", self.times.len()),
                format!("timestamp {t_s} s is not finite or does not increase (as a 32-bit float)"),
            ));
        }
        let n = self.times.len();
        self.times.push(t_s);
        for h in hands {
            let Some(joints) = h.joints_3d_mm else {
                continue;
            };
            if joints.iter().flatten().any(|v| !v.is_finite()) {
                continue;
            }
            let key = track_key(h);
            let i = match self.tracks.iter().position(|t| (t.id, t.side) == key) {
                Some(i) => i,
                None => {
                    self.tracks.push(Track {
                        side: h.side,
                        id: h.id,
                        start: n,
                        samples: Vec::new(),
                    });
                    self.tracks.len() - 1
                }
            };
            let track = &mut self.tracks[i];
            let k = n - track.start;
            if track.samples.len() <= k {
                track.samples.resize(k + 1, None);
            }
            if track.samples[k].is_none() {
                track.samples[k] = Some(joints.map(to_gltf));
            }
        }
        Ok(())
    }

    /// [`GltfWriter::add_frame`] with the hands of a frame record.
    pub fn add_record(&mut self, t_s: f64, frame: &FrameRecord) -> IoResult<()> {
        self.add_frame(t_s, &frame.hands)
    }

    /// The whole `.glb` file as bytes.
    pub fn to_glb(&self) -> Vec<u8> {
        let mut scene = GlbScene::new();
        // The camera, at the origin looking along -z as the real camera.
        let mut cam = json!({"type": "perspective", "perspective": {
            "yfov": self.yfov_rad, "znear": 0.01, "zfar": 100.0}});
        if let Some(a) = self.aspect {
            cam["perspective"]["aspectRatio"] = json!(a);
        }
        scene.nodes.push(json!({"name": "camera", "camera": 0}));
        scene.scene_roots.push(0);
        for track in &self.tracks {
            scene.add_track(track, &self.times, self.meshes.as_deref());
        }
        scene.finish(cam)
    }

    /// Writes the file (to `PATH.tmp`, then renamed to `PATH`; complete or absent).
    pub fn finish(self) -> IoResult<()> {
        write_file_atomically(&self.path, &self.to_glb())
    }
}

/// Index of a side in per-side arrays: left 0, right 1.
fn side_index(s: HandSide) -> usize {
    match s {
        HandSide::Left => 0,
        HandSide::Right => 1,
    }
}

/// The keys of one track, which the nodes of its hand are animated over.
struct TrackKeys {
    /// Which hand.
    side: HandSide,
    /// The track's id as named in its nodes (`na` without one).
    id: String,
    /// The accessor of the key times; `None` without keys.
    time_acc: Option<usize>,
    /// The joints at each key, gaps filled (see [`fill_gaps`]).
    filled: Vec<[[f32; 3]; NUM_JOINTS]>,
    /// Whether the hand was seen at each key.
    visible: Vec<bool>,
}

/// A `.glb` under construction: its binary data and the JSON arrays the hands are
/// added to in turn. The joint and bone geometry, its materials and meshes are added when
/// a hand first needs them, so that a file holds no object it does not use (the Khronos
/// validator's `UNUSED_OBJECT`).
struct GlbScene {
    b: GlbBuilder,
    materials: Vec<Value>,
    /// Every mesh: the joint and bone meshes and the skinned meshes, as first used.
    meshes: Vec<Value>,
    /// Index of each side's skinned mesh, once added.
    skinned_mesh: [Option<usize>; 2],
    skins: Vec<Value>,
    nodes: Vec<Value>,
    scene_roots: Vec<usize>,
    channels: Vec<Value>,
    samplers: Vec<Value>,
    /// The accessor of the joint and bone triangles, once added.
    shape_indices: Option<usize>,
    /// The joint mesh of each side, once added.
    side_mesh: [Option<usize>; 2],
    /// The bone mesh of each finger, once added.
    finger_mesh: Option<Vec<usize>>,
}

impl GlbScene {
    /// An empty scene.
    fn new() -> GlbScene {
        GlbScene {
            b: GlbBuilder::default(),
            materials: Vec::new(),
            meshes: Vec::new(),
            skinned_mesh: [None, None],
            skins: Vec::new(),
            nodes: Vec::new(),
            scene_roots: Vec::new(),
            channels: Vec::new(),
            samplers: Vec::new(),
            shape_indices: None,
            side_mesh: [None, None],
            finger_mesh: None,
        }
    }

    /// Adds a material of the colour `rgb` (sRGB) and `roughness`; returns its index.
    fn material(&mut self, name: &str, rgb: [u8; 3], roughness: f64) -> usize {
        let c: Vec<f64> = rgb.iter().map(|&v| srgb_to_linear(v)).collect();
        self.materials
            .push(json!({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": [c[0], c[1], c[2], 1.0], "metallicFactor": 0.0,
            "roughnessFactor": roughness}}));
        self.materials.len() - 1
    }

    /// Adds a mesh of the joint and bone triangles over the vertices `pos` (an accessor)
    /// with its own material; returns its index.
    fn shape_mesh(&mut self, name: &str, pos: usize, rgb: [u8; 3]) -> usize {
        let b = &mut self.b;
        let idx = *self
            .shape_indices
            .get_or_insert_with(|| b.index_accessor(&double_pyramid_indices()));
        let mat = self.material(name, rgb, 0.6);
        self.meshes.push(
            json!({"name": name, "primitives": [{"attributes": {"POSITION": pos},
            "indices": idx, "material": mat, "mode": 4}]}),
        );
        self.meshes.len() - 1
    }

    /// The joint mesh of `side` (an octahedron in the side's colour), added on first use.
    fn side_mesh(&mut self, side: HandSide) -> usize {
        if let Some(m) = self.side_mesh[side_index(side)] {
            return m;
        }
        let r = JOINT_RADIUS_M;
        let pos = double_pyramid((r, r), (r, r), (r, r), [0.0; 3]);
        let acc = self.b.vec3_accessor(&pos, Some(34962));
        let m = self.shape_mesh(
            &format!("{side}_joint"),
            acc,
            crate::palette::side_color(side),
        );
        self.side_mesh[side_index(side)] = Some(m);
        m
    }

    /// The bone mesh of each finger (a pyramid with its base at the origin and its tip at
    /// +Y 1, in the finger's colour), added on first use.
    fn finger_meshes(&mut self) -> Vec<usize> {
        if let Some(m) = &self.finger_mesh {
            return m.clone();
        }
        let w = BONE_HALF_WIDTH_M;
        let pos = double_pyramid(
            (w, w),
            (BONE_WAIST, 1.0 - BONE_WAIST),
            (w, w),
            [0.0, BONE_WAIST, 0.0],
        );
        let acc = self.b.vec3_accessor(&pos, Some(34962));
        let m: Vec<usize> = monohand_core::hand_model::Finger::ALL
            .iter()
            .map(|f| {
                self.shape_mesh(
                    &format!("{}_bone", f.name()),
                    acc,
                    crate::palette::FINGER_COLORS[f.index()],
                )
            })
            .collect();
        self.finger_mesh = Some(m.clone());
        m
    }

    /// Adds the hand of a track (times of all frames in `times`): a skinned mesh of
    /// `meshes` (left, right) when given, else joints and bones.
    fn add_track(&mut self, track: &Track, times: &[f64], meshes: Option<&[HandMesh; 2]>) {
        let (first, samples) = track.keyed(times.len());
        let times: Vec<f32> = times
            .iter()
            .skip(first)
            .take(samples.len())
            .map(|&t| t as f32)
            .collect();
        let time_acc = (!times.is_empty()).then(|| self.b.scalar_accessor(&times));
        let keys = TrackKeys {
            side: track.side,
            id: track.id.map_or("na".to_string(), |i| i.to_string()),
            time_acc,
            filled: fill_gaps(&samples),
            visible: samples.iter().map(Option::is_some).collect(),
        };
        let (children, skinned) = match meshes {
            Some(meshes) => self.add_skinned_hand(&keys, &meshes[side_index(track.side)]),
            None => {
                let mut children = self.add_joint_nodes(&keys);
                children.extend(self.add_bone_nodes(&keys));
                (children, None)
            }
        };
        let (id, side) = (&keys.id, keys.side);
        let hand = self.nodes.len();
        self.nodes
            .push(json!({"name": format!("hand_{id}_{side}"), "children": children}));
        self.scene_roots.push(hand);
        // A skinned mesh's node is a root of the scene: its skin's joints place it, and a
        // parent's transform would not (the validator's `NODE_SKINNED_MESH_NON_ROOT`).
        self.scene_roots.extend(skinned);
    }

    /// Animates the `path` of `node` with `data` (`comps` floats a key) at the keys of
    /// the accessor `input` (nothing without keys); `step` for step interpolation, else
    /// linear.
    fn animate(
        &mut self,
        input: Option<usize>,
        node: usize,
        path: &str,
        data: Vec<f32>,
        comps: usize,
        step: bool,
    ) {
        let Some(input) = input else { return };
        let out = self.b.float_accessor(&data, comps);
        let sampler = json!({"input": input, "output": out,
            "interpolation": if step { "STEP" } else { "LINEAR" }});
        self.samplers.push(sampler);
        let channel = json!({"sampler": self.samplers.len() - 1,
            "target": {"node": node, "path": path}});
        self.channels.push(channel);
    }

    /// Adds a hand drawn as `mesh` skinned to animated joint nodes (its skin, the joint
    /// nodes and the mesh node); returns the joint nodes, to put under the hand's node,
    /// and the mesh node, a root of the scene.
    fn add_skinned_hand(&mut self, k: &TrackKeys, mesh: &HandMesh) -> (Vec<usize>, Option<usize>) {
        let (id, side) = (&k.id, k.side);
        let si = side_index(side);
        let mi = match self.skinned_mesh[si] {
            Some(mi) => mi,
            None => {
                let mi = self.add_skinned_mesh(mesh);
                self.skinned_mesh[si] = Some(mi);
                mi
            }
        };
        let ibm = self.b.raw_accessor(&mesh.inverse_bind);
        let poses = skinned_poses(mesh, &k.filled);
        let mut joint_nodes = Vec::new();
        for (ji, (name, _)) in MESH_JOINTS.iter().enumerate() {
            let node = self.nodes.len();
            joint_nodes.push(node);
            let (mut tr, mut rot, mut sc) = (Vec::new(), Vec::new(), Vec::new());
            let mut prev_q: Option<[f32; 4]> = None;
            for (p, &v) in poses.iter().zip(&k.visible) {
                let jp = p.map(|p| p[ji]);
                let t = jp.map_or([0.0; 3], |j| j.translation);
                let mut q = jp.map_or([0.0, 0.0, 0.0, 1.0], |j| j.rotation);
                if let Some(pq) = prev_q {
                    if pq.iter().zip(&q).map(|(x, y)| x * y).sum::<f32>() < 0.0 {
                        q = q.map(|x| -x);
                    }
                }
                prev_q = Some(q);
                let s = if v { jp.map_or(0.0, |j| j.scale) } else { 0.0 };
                tr.extend(t);
                rot.extend(q);
                sc.extend([s; 3]);
            }
            let mut n = json!({"name": format!("{name}_{id}_{side}")});
            if let (Some(t0), Some(r0), Some(s0)) = (tr.get(0..3), rot.get(0..4), sc.get(0..3)) {
                n["translation"] = json!(t0);
                n["rotation"] = json!(r0);
                n["scale"] = json!(s0);
            }
            self.nodes.push(n);
            self.animate(k.time_acc, node, "translation", tr, 3, false);
            self.animate(k.time_acc, node, "rotation", rot, 4, false);
            self.animate(k.time_acc, node, "scale", sc, 3, true);
        }
        let skin = json!({"name": format!("skin_{id}_{side}"),
            "inverseBindMatrices": ibm, "joints": joint_nodes});
        self.skins.push(skin);
        let node = self.nodes.len();
        let mesh_node = json!({"name": format!("mesh_{id}_{side}"),
            "mesh": mi, "skin": self.skins.len() - 1});
        self.nodes.push(mesh_node);
        (joint_nodes, Some(node))
    }

    /// Adds a side's skinned mesh (its vertex data, and a material in the side's colour);
    /// returns its index among the meshes.
    fn add_skinned_mesh(&mut self, mesh: &HandMesh) -> usize {
        let mut attributes = serde_json::Map::new();
        for (name, raw) in &mesh.attributes {
            attributes.insert(name.to_string(), json!(self.b.raw_accessor(raw)));
        }
        let indices = self.b.raw_accessor(&mesh.indices);
        let material = self.material(
            &format!("{}_skin", mesh.side),
            crate::palette::side_color(mesh.side),
            0.55,
        );
        self.meshes.push(
            json!({"name": format!("{}_hand", mesh.side), "primitives": [{
            "attributes": attributes, "indices": indices, "material": material,
            "mode": 4}]}),
        );
        self.meshes.len() - 1
    }

    /// Adds the 21 joint nodes of a hand drawn as joints and bones; returns them.
    fn add_joint_nodes(&mut self, k: &TrackKeys) -> Vec<usize> {
        let (id, side) = (&k.id, k.side);
        let mesh = self.side_mesh(side);
        let mut children = Vec::new();
        for (j, name) in JOINT_NAMES.iter().enumerate() {
            let node = self.nodes.len();
            let first = k.filled.first().map_or([0.0; 3], |f| f[j]);
            let joint = json!({"name": format!("{name}_{id}_{side}"),
                "mesh": mesh, "translation": first});
            self.nodes.push(joint);
            children.push(node);
            let tr: Vec<f32> = k.filled.iter().flat_map(|f| f[j]).collect();
            let sc: Vec<f32> = k
                .visible
                .iter()
                .flat_map(|&v| if v { [1.0; 3] } else { [0.0; 3] })
                .collect();
            self.animate(k.time_acc, node, "translation", tr, 3, false);
            self.animate(k.time_acc, node, "scale", sc, 3, true);
        }
        children
    }

    /// Adds the 20 bone nodes of a hand drawn as joints and bones; returns them.
    fn add_bone_nodes(&mut self, k: &TrackKeys) -> Vec<usize> {
        let (id, side) = (&k.id, k.side);
        let finger_mesh = self.finger_meshes();
        let mut children = Vec::new();
        for &(a, c) in &BONES {
            let node = self.nodes.len();
            let finger = (c - 1) / 4;
            let bone = json!({"name": format!("bone_{}_{}_{id}_{side}",
                JOINT_NAMES[a], JOINT_NAMES[c]), "mesh": finger_mesh[finger]});
            self.nodes.push(bone);
            children.push(node);
            let (mut tr, mut rot, mut sc) = (Vec::new(), Vec::new(), Vec::new());
            let mut prev_q: Option<[f32; 4]> = None;
            for (f, &v) in k.filled.iter().zip(&k.visible) {
                let (p, q) = (f[a], f[c]);
                let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let mut rq = if len > 1e-7 {
                    rotation_from_y(d.map(|x| x / len))
                } else {
                    prev_q.unwrap_or([0.0, 0.0, 0.0, 1.0])
                };
                // Stay in the hemisphere of the previous key so interpolation takes the short way.
                if let Some(pq) = prev_q {
                    if pq.iter().zip(&rq).map(|(x, y)| x * y).sum::<f32>() < 0.0 {
                        rq = rq.map(|x| -x);
                    }
                }
                prev_q = Some(rq);
                tr.extend(p);
                rot.extend(rq);
                sc.extend(if v { [1.0, len, 1.0] } else { [0.0; 3] });
            }
            if let (Some(t0), Some(r0)) = (tr.get(0..3), rot.get(0..4)) {
                self.nodes[node]["translation"] = json!(t0);
                self.nodes[node]["rotation"] = json!(r0);
            }
            self.animate(k.time_acc, node, "translation", tr, 3, false);
            self.animate(k.time_acc, node, "rotation", rot, 4, false);
            self.animate(k.time_acc, node, "scale", sc, 3, true);
        }
        children
    }

    /// The `.glb` of the scene with the camera `cam`.
    fn finish(self, cam: Value) -> Vec<u8> {
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": concat!("monohand-io ", env!("CARGO_PKG_VERSION"))},
            "scene": 0,
            "scenes": [{"name": "monohand", "nodes": self.scene_roots}],
            "nodes": self.nodes,
            "cameras": [cam],
        });
        if !self.meshes.is_empty() {
            doc["materials"] = json!(self.materials);
            doc["meshes"] = json!(self.meshes);
        }
        if !self.skins.is_empty() {
            doc["skins"] = json!(self.skins);
            doc["asset"]["copyright"] = json!(MESH_CREDIT);
        }
        if !self.channels.is_empty() {
            doc["animations"] =
                json!([{"name": "tracking", "channels": self.channels, "samplers": self.samplers}]);
        }
        self.b.finish(doc)
    }
}

/// The pose of a skinned mesh at each key: frames with a degenerate fit keep the last
/// pose (the first pose before it).
fn skinned_poses(
    mesh: &HandMesh,
    filled: &[[[f32; 3]; NUM_JOINTS]],
) -> Vec<Option<[JointPose; MESH_JOINTS.len()]>> {
    let mut poses = Vec::with_capacity(filled.len());
    let mut last = None;
    for f in filled {
        if let Some(p) = mesh.pose(f) {
            last = Some(p);
        }
        poses.push(last);
    }
    let first = poses.iter().flatten().next().copied();
    poses.into_iter().map(|p| p.or(first)).collect()
}

/// Replaces the gaps of a track by the nearest earlier sample (or, before the
/// first one, the first), so hidden hands do not fly to the origin.
fn fill_gaps(samples: &[Option<[[f32; 3]; NUM_JOINTS]>]) -> Vec<[[f32; 3]; NUM_JOINTS]> {
    let first = samples
        .iter()
        .flatten()
        .next()
        .copied()
        .unwrap_or([[0.0; 3]; NUM_JOINTS]);
    let mut last = first;
    samples
        .iter()
        .map(|s| {
            if let Some(s) = s {
                last = *s;
            }
            last
        })
        .collect()
}

/// sRGB 8-bit to linear, as glTF's `baseColorFactor` is linear.
fn srgb_to_linear(v: u8) -> f64 {
    let c = v as f64 / 255.0;
    let l = if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    };
    (l * 1e4).round() / 1e4
}

/// Collects binary data, buffer views and accessors of a GLB.
#[derive(Default)]
struct GlbBuilder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl GlbBuilder {
    /// Appends bytes as a new buffer view (4-byte aligned); returns its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn floats(data: &[f32]) -> Vec<u8> {
        data.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// A float accessor of `comps` components (1, 3 or 4) with min/max.
    fn float_accessor(&mut self, data: &[f32], comps: usize) -> usize {
        self.float_accessor_target(data, comps, None)
    }

    fn float_accessor_target(&mut self, data: &[f32], comps: usize, target: Option<u32>) -> usize {
        let view = self.view(&Self::floats(data), target);
        let mut min = vec![f32::INFINITY; comps];
        let mut max = vec![f32::NEG_INFINITY; comps];
        for chunk in data.chunks(comps) {
            for (k, &v) in chunk.iter().enumerate() {
                min[k] = min[k].min(v);
                max[k] = max[k].max(v);
            }
        }
        let ty = match comps {
            1 => "SCALAR",
            3 => "VEC3",
            _ => "VEC4",
        };
        self.accessors
            .push(json!({"bufferView": view, "componentType": 5126,
            "count": data.len() / comps, "type": ty, "min": min, "max": max}));
        self.accessors.len() - 1
    }

    fn vec3_accessor(&mut self, pos: &[[f32; 3]], target: Option<u32>) -> usize {
        let flat: Vec<f32> = pos.iter().flatten().copied().collect();
        self.float_accessor_target(&flat, 3, target)
    }

    fn scalar_accessor(&mut self, data: &[f32]) -> usize {
        self.float_accessor(data, 1)
    }

    /// An accessor copied from another file (see [`crate::hand_mesh::RawAccessor`]).
    fn raw_accessor(&mut self, raw: &crate::hand_mesh::RawAccessor) -> usize {
        let view = self.view(&raw.bytes, raw.target);
        let mut a = raw.accessor.clone();
        a["bufferView"] = json!(view);
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn index_accessor(&mut self, idx: &[u16]) -> usize {
        let bytes: Vec<u8> = idx.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        self.accessors
            .push(json!({"bufferView": view, "componentType": 5123,
            "count": idx.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }

    /// The GLB container: header, JSON chunk, BIN chunk.
    fn finish(mut self, mut doc: Value) -> Vec<u8> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        doc["buffers"] = json!([{"byteLength": self.bin.len()}]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        let mut js = doc.to_string().into_bytes();
        while !js.len().is_multiple_of(4) {
            js.push(b' ');
        }
        let total = 12 + 8 + js.len() + 8 + self.bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(js.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&js);
        out.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&self.bin);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn bone_rotation_turns_y_onto_the_bone() {
        for d in [
            [1.0f32, 0.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.6, 0.0, 0.8],
            [0.0, 1.0, 0.0],
        ] {
            let [x, y, z, w] = rotation_from_y(d);
            // Rotate (0, 1, 0) by q: v' = v + 2w (q x v) + 2 q x (q x v).
            let q = Vector3::new(x, y, z);
            let v = Vector3::new(0.0, 1.0, 0.0);
            let t = q.cross(&v) * 2.0;
            let r = v + t * w + q.cross(&t);
            assert!((r - Vector3::from(d)).norm() < 1e-5, "{d:?} -> {r:?}");
        }
        // Winding: every octahedron face normal points away from the centre.
        let pos = double_pyramid((1.0, 1.0), (1.0, 1.0), (1.0, 1.0), [0.0; 3]);
        for t in double_pyramid_indices().chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vector3::from(pos[i as usize]));
            let n = (b - a).cross(&(c - a));
            assert!(n.dot(&(a + b + c)) > 0.0, "{t:?}");
        }
    }
}
