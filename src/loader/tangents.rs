//! Tangents for normal maps when a primitive has none: MikkTSpace, as glTF
//! asks and as Blender computes them for Cycles' Normal Map node, so a
//! normal map baked in Blender looks the same in both renderers. The
//! implementation is bevy_mikktspace, a safe port that gives the reference
//! C code's results bit for bit.

use bevy_mikktspace::{generate_tangents, Geometry, TangentSpace};

/// A triangle list by corner: triangle k is corners 3k, 3k+1, 3k+2
/// (MikkTSpace welds equal corners itself).
struct Primitive {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    /// One tangent per corner, w = the bitangent's sign.
    out: Vec<[f32; 4]>,
}

impl Primitive {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        face * 3 + vert
    }
}

impl Geometry for Primitive {
    fn num_faces(&self) -> usize {
        self.out.len() / 3
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[self.vertex(face, vert)]
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[self.vertex(face, vert)]
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.vertex(face, vert)]
    }
    fn set_tangent(&mut self, tangent_space: Option<TangentSpace>, face: usize, vert: usize) {
        if let Some(t) = tangent_space {
            self.out[face * 3 + vert] = t.tangent_encoded();
        }
    }
}

/// Zero for a non-finite value.
fn finite<const N: usize>(v: [f32; N]) -> [f32; N] {
    if v.iter().all(|c| c.is_finite()) { v } else { [0.0; N] }
}

/// Object-space tangents of a triangle list given by corner (all three
/// slices of one length, a multiple of 3): one per corner, zero where the
/// algorithm finds none, which shading treats as "no normal map here".
/// Non-finite inputs are zeroed first.
pub fn mikktspace(positions: &[[f32; 3]], normals: &[[f32; 3]], uvs: &[[f32; 2]]) -> Vec<[f32; 4]> {
    let corners = positions.len();
    let mut primitive = Primitive {
        positions: positions.iter().copied().map(finite).collect(),
        normals: normals.iter().copied().map(finite).collect(),
        uvs: uvs.iter().copied().map(finite).collect(),
        out: vec![[0.0; 4]; corners],
    };
    // The port is safe Rust and returns no errors; a panic inside it would
    // still be a bug of ours to report, not a reason to take the renderer down.
    let ok = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| generate_tangents(&mut primitive).is_ok())).unwrap_or(false);
    if ok { primitive.out } else { vec![[0.0; 4]; corners] }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quad in the XY plane facing +Z with u along +X and v along −Y
    /// (glTF's v runs down the image): the tangent is +X, and the
    /// bitangent sign makes B = sign·(N × T) point along +v, i.e. −Y.
    #[test]
    fn tangent_follows_u_and_the_sign_follows_v() {
        let corners = |v: [[f32; 2]; 4]| [0, 1, 2, 0, 2, 3].map(|i| v[i]);
        let positions = [0, 1, 2, 0, 2, 3].map(|i| [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]][i]);
        let normals = [[0.0, 0.0, 1.0]; 6];
        let uvs = corners([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]);
        let t = mikktspace(&positions, &normals, &uvs);
        for c in &t {
            assert!((c[0] - 1.0).abs() < 1e-5 && c[1].abs() < 1e-5 && c[2].abs() < 1e-5, "{c:?}");
            assert_eq!(c[3], -1.0, "N × T = +Y is against +v's direction (−Y): {c:?}");
        }
        // Mirrored UVs flip the sign.
        let mirrored = corners([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        let t = mikktspace(&positions, &normals, &mirrored);
        assert!(t.iter().all(|c| c[3] == 1.0), "{t:?}");
    }

    #[test]
    fn degenerate_and_broken_input_gives_finite_tangents() {
        let positions = [[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0; 3]];
        let t = mikktspace(&positions, &[[0.0; 3]; 6], &[[f32::INFINITY, 0.0]; 6]);
        assert_eq!(t.len(), 6);
        assert!(t.iter().flatten().all(|v| v.is_finite()));
    }
}
