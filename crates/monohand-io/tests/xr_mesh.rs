//! The OpenXR joints' radii and metacarpal joints (`monohand_core::xr`) measured again on
//! the hand mesh they were taken from: the WebXR generic hand built into the library.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

use monohand_core::hand_model::HandSide;
use monohand_core::xr::{
    XR_JOINT_COUNT, XR_JOINT_NAMES, XR_MESH_HAND_LENGTH_MM, XR_MESH_RADII_MM,
    XR_METACARPAL_FRACTION, XR_PALM,
};
use monohand_io::hand_mesh::{HandMesh, MESH_JOINTS};
use nalgebra::Vector3;

/// The mesh's triangles, metres (its bind pose: the joints' frame).
fn triangles(mesh: &HandMesh) -> Vec<[Vector3<f64>; 3]> {
    let (name, pos) = &mesh.attributes[0];
    assert_eq!(*name, "POSITION");
    let floats: Vec<f64> = pos
        .bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64)
        .collect();
    let vertices: Vec<Vector3<f64>> = floats
        .chunks_exact(3)
        .map(|v| Vector3::new(v[0], v[1], v[2]))
        .collect();
    assert_eq!(mesh.indices.accessor["componentType"], 5123, "u16 indices");
    let indices: Vec<usize> = mesh
        .indices
        .bytes
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]) as usize)
        .collect();
    indices
        .chunks_exact(3)
        .map(|t| [vertices[t[0]], vertices[t[1]], vertices[t[2]]])
        .collect()
}

/// The point of triangle `abc` nearest to `p` (Ericson, Real-Time Collision Detection, 5.1.5).
fn nearest_on_triangle(p: Vector3<f64>, [a, b, c]: [Vector3<f64>; 3]) -> Vector3<f64> {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Distance from `p` to the mesh's surface, mm.
fn to_skin_mm(tris: &[[Vector3<f64>; 3]], p: Vector3<f64>) -> f64 {
    tris.iter()
        .map(|t| (nearest_on_triangle(p, *t) - p).norm())
        .fold(f64::INFINITY, f64::min)
        * 1000.0
}

/// The mesh's joint positions (metres) and, in `XrHandJointEXT` order, each joint's
/// distance to the skin (mm): the mesh's 25 joints are OpenXR's after the palm, whose
/// place is the middle of the middle finger's metacarpal.
fn measure(side: HandSide) -> (Vec<Vector3<f64>>, [f64; XR_JOINT_COUNT]) {
    let mesh = HandMesh::webxr(side).unwrap();
    let tris = triangles(&mesh);
    let at: Vec<Vector3<f64>> = (0..MESH_JOINTS.len())
        .map(|k| Vector3::from(mesh.rest_position(k).unwrap()))
        .collect();
    let radii = std::array::from_fn(|i| match i {
        XR_PALM => to_skin_mm(&tris, (at[10] + at[11]) / 2.0),
        i => to_skin_mm(&tris, at[i - 1]),
    });
    (at, radii)
}

#[test]
fn the_mesh_joints_are_openxrs_after_the_palm() {
    // WebXR's names (the mesh's) and OpenXR's name the same joints in the same order.
    for (k, (webxr, _)) in MESH_JOINTS.iter().enumerate() {
        let openxr = XR_JOINT_NAMES[k + 1]
            .replace("little", "pinky")
            .replace("_proximal", "_phalanx_proximal")
            .replace("_intermediate", "_phalanx_intermediate")
            .replace("_distal", "_phalanx_distal");
        let webxr = webxr.replace("-finger", "").replace('-', "_");
        assert_eq!(webxr, openxr);
    }
}

#[test]
fn radii_and_metacarpals_are_the_meshs() {
    let (at, radii) = measure(HandSide::Right);
    for i in 0..XR_JOINT_COUNT {
        println!("{:>20} {:5.2} mm", XR_JOINT_NAMES[i], radii[i]);
        assert!(
            (radii[i] - XR_MESH_RADII_MM[i]).abs() <= 0.051,
            "{}: the mesh says {:.2} mm, the table {}",
            XR_JOINT_NAMES[i],
            radii[i],
            XR_MESH_RADII_MM[i]
        );
    }
    // The size they were measured at: wrist to middle MCP, then the middle finger.
    let length = ((at[11] - at[0]).norm()
        + (at[12] - at[11]).norm()
        + (at[13] - at[12]).norm()
        + (at[14] - at[13]).norm())
        * 1000.0;
    println!("hand length {length:.2} mm");
    assert!((length - XR_MESH_HAND_LENGTH_MM).abs() < 0.05, "{length}");
    // Each finger's metacarpal joint along its wrist-to-knuckle line.
    for (f, fraction) in XR_METACARPAL_FRACTION.iter().enumerate() {
        let (meta, knuckle) = (at[5 + 5 * f], at[6 + 5 * f]);
        let line = knuckle - at[0];
        let t = (meta - at[0]).dot(&line) / line.norm_squared();
        println!(
            "finger {}: metacarpal at {t:.3} of the wrist-knuckle line",
            f + 1
        );
        assert!((t - fraction).abs() < 0.006, "finger {}: {t}", f + 1);
    }
}

#[test]
fn the_left_mesh_is_nearly_the_mirror_of_the_right() {
    // The tables are the right mesh's, and a left hand is the right's mirror. The artist's
    // left hand is nearly that too.
    let (_, right) = measure(HandSide::Right);
    let (_, left) = measure(HandSide::Left);
    for i in 0..XR_JOINT_COUNT {
        println!(
            "{:>20} right {:5.2} left {:5.2}",
            XR_JOINT_NAMES[i], right[i], left[i]
        );
        assert!((right[i] - left[i]).abs() < 1.0, "{}", XR_JOINT_NAMES[i]);
    }
}
