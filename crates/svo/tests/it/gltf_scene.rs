//! glTF lights (`KHR_lights_punctual`) and cameras come in with the mesh, placed by their
//! nodes' transforms; directional lights and orthographic cameras are left out; malformed
//! ones never panic; a bake stores them in the `.svo`.
#![cfg(all(feature = "gltf", feature = "io"))]

use serde_json::{Value, json};
use svo::{Mesh, MeshFormat};

/// A red unit box as glTF JSON and its binary buffer (8 corners, 12 triangles): the shape of
/// the Khronos `Box` sample (a root node turned by a matrix, holding the mesh's node).
fn box_gltf() -> (Value, Vec<u8>) {
    let mut bin = Vec::new();
    for i in 0..8u32 {
        for axis in 0..3 {
            let c: f32 = if i >> axis & 1 == 1 { 0.5 } else { -0.5 };
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    // Two triangles per face, corners as bit patterns (x = bit 0, y = bit 1, z = bit 2).
    let faces: [[u16; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    for [a, b, c, d] in faces {
        for i in [a, b, c, a, c, d] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
    }
    let j = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 96},
            {"buffer": 0, "byteOffset": 96, "byteLength": 72}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5]},
            {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}
        ],
        "materials": [{"name": "Red", "pbrMetallicRoughness":
            {"baseColorFactor": [0.8, 0.0, 0.0, 1.0], "metallicFactor": 0.0}}],
        "meshes": [{"name": "Mesh", "primitives":
            [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4, "material": 0}]}],
        "nodes": [
            {"children": [1], "matrix": [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0,
                                         0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]},
            {"mesh": 0}
        ],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    (j, bin)
}

/// A binary glTF (GLB) of `json` and its buffer.
pub(crate) fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).unwrap();
    text.resize(text.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    let u32le = |v: usize| u32::try_from(v).unwrap().to_le_bytes();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&u32le(total));
    out.extend_from_slice(&u32le(text.len()));
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&u32le(bin.len()));
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// [`box_gltf`] with lights and cameras added, then `extra`, as a GLB.
fn box_with(extra: impl FnOnce(&mut Value)) -> Vec<u8> {
    let (mut j, bin) = box_gltf();
    j["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    j["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 12.0},
        {"type": "directional", "intensity": 3.0},
        {"type": "spot", "intensity": 5.0, "spot": {}, "name": "spot"}
    ]}});
    j["cameras"] = json!([
        {"type": "perspective", "name": "front", "perspective": {"yfov": 0.7, "znear": 0.1}},
        {"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "zfar": 10.0, "znear": 0.1}}
    ]);
    let nodes = j["nodes"].as_array_mut().unwrap();
    let base = nodes.len();
    nodes.extend([
        // A light under a scaled, moved parent: at (0, 0, 5) + 2 * (1, 0, 0).
        json!({"translation": [0.0, 0.0, 5.0], "scale": [2.0, 2.0, 2.0], "children": [base + 1]}),
        json!({"translation": [1.0, 0.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}),
        json!({"extensions": {"KHR_lights_punctual": {"light": 1}}}),
        // Turned 90 degrees about +y: looking along -x.
        json!({"camera": 0, "translation": [0.0, 1.0, 4.0],
               "rotation": [0.0, std::f64::consts::FRAC_1_SQRT_2, 0.0, std::f64::consts::FRAC_1_SQRT_2]}),
        json!({"camera": 1}),
        json!({"translation": [0.0, -1.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 2}}}),
    ]);
    j["scenes"][0]["nodes"] = json!([0, base, base + 2, base + 3, base + 4, base + 5]);
    extra(&mut j);
    glb(&j, &bin)
}

#[test]
fn lights_and_cameras_are_placed_by_their_nodes() {
    let bytes = box_with(|_| {});
    let mesh = Mesh::from_bytes(&bytes, MeshFormat::Gltf).unwrap();
    let s = &mesh.scene;
    // The point light and the spot (as a point light); not the directional one.
    assert_eq!(s.lights.len(), 2, "{s:?}");
    assert_eq!(s.lights[0].colour, [1.0, 0.5, 0.25]);
    assert_eq!(s.lights[0].intensity, 12.0);
    let p = glam::DVec3::from_array(s.lights[0].position);
    assert!(p.abs_diff_eq(glam::DVec3::new(2.0, 0.0, 5.0), 1e-6), "{p}");
    assert!(glam::DVec3::from_array(s.lights[1].position).abs_diff_eq(glam::DVec3::NEG_Y, 1e-6));
    // The perspective camera only.
    assert_eq!(s.cameras.len(), 1, "{s:?}");
    let c = &s.cameras[0];
    assert_eq!(c.name, "front");
    assert!(
        (c.fov_deg - 0.7f64.to_degrees()).abs() < 1e-4,
        "{}",
        c.fov_deg
    );
    let eye = glam::DVec3::from_array(c.eye);
    let dir = glam::DVec3::from_array(c.target) - eye;
    assert!(
        eye.abs_diff_eq(glam::DVec3::new(0.0, 1.0, 4.0), 1e-6),
        "{eye}"
    );
    assert!(
        dir.normalize().abs_diff_eq(glam::DVec3::NEG_X, 1e-6),
        "{dir}"
    );
    assert!(glam::DVec3::from_array(c.up).abs_diff_eq(glam::DVec3::Y, 1e-6));
    // A bake keeps them.
    let (tree, _) = svo::bake_mesh(
        &mesh,
        &svo::BakeOptions {
            depth: 3,
            ..Default::default()
        },
    )
    .unwrap();
    // A file keeps them (what `svo-bake` records of a mesh file's bake).
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("box.svo");
    let info = svo::io::BuildInfo {
        scene: mesh.scene.clone(),
        ..svo::io::BuildInfo::new()
    };
    svo::io::write_file(&tree, &info, &out).unwrap();
    let (back, build) = svo::io::read_file(&out).unwrap();
    assert_eq!(back, tree);
    assert_eq!(&build.scene, s);
}

#[test]
fn malformed_lights_and_cameras_never_panic() {
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<Edit> = vec![
        // A spot light without its spot parameters.
        Box::new(|j| {
            j["extensions"]["KHR_lights_punctual"]["lights"][2] =
                json!({"type": "spot", "intensity": 1.0})
        }),
        // A light of unknown type, a light index out of range.
        Box::new(|j| j["extensions"]["KHR_lights_punctual"]["lights"][0]["type"] = json!("area")),
        Box::new(|j| j["nodes"][3]["extensions"]["KHR_lights_punctual"]["light"] = json!(99)),
        // Lights without the extension table.
        Box::new(|j| j["extensions"] = json!({})),
        // A perspective camera without its parameters, an orthographic one without its own,
        // a camera index out of range, a camera of unknown type.
        Box::new(|j| j["cameras"][0] = json!({"type": "perspective"})),
        Box::new(|j| j["cameras"][1] = json!({"type": "orthographic"})),
        Box::new(|j| j["nodes"][5]["camera"] = json!(7)),
        Box::new(|j| j["cameras"][0]["type"] = json!("fisheye")),
        // Non-finite or degenerate values.
        Box::new(|j| {
            j["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(-1.0)
        }),
        Box::new(|j| j["cameras"][0]["perspective"]["yfov"] = json!(0.0)),
        Box::new(|j| j["nodes"][5]["scale"] = json!([0.0, 0.0, 0.0])),
    ];
    for (i, f) in cases.iter().enumerate() {
        let bytes = box_with(f);
        match Mesh::from_bytes(&bytes, MeshFormat::Gltf) {
            Ok(m) => m.scene.validate().unwrap(),
            Err(e) => assert!(!e.to_string().is_empty(), "case {i}"),
        }
    }
}
