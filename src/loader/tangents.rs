//! Tangents for normal maps when a primitive has none: MikkTSpace, as glTF
//! asks and as Blender computes them for Cycles' Normal Map node, so a
//! normal map baked in Blender looks the same in both renderers. The
//! implementation is bevy_mikktspace, a safe port that gives the reference
//! C code's results bit for bit.

use bevy_mikktspace::{generate_tangents, Geometry, TangentSpace};

struct Primitive<'a> {
    indices: &'a [u32],
    positions: &'a [[f32; 3]],
    normals: &'a [[f32; 3]],
    uvs: &'a [[f32; 2]],
    /// One tangent per index (corner), w = the bitangent's sign.
    out: Vec<[f32; 4]>,
}

impl Primitive<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.indices[face * 3 + vert] as usize
    }
}

impl Geometry for Primitive<'_> {
    fn num_faces(&self) -> usize {
        self.indices.len() / 3
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

/// Object-space tangents of an indexed triangle list, one per corner
/// (`indices.len()` entries; zero where the algorithm finds none, which
/// shading treats as "no normal map here"). Non-finite inputs are zeroed
/// first. `indices` must be in range and a multiple of 3 long.
pub fn mikktspace(indices: &[u32], positions: &[[f32; 3]], normals: &[[f32; 3]], uvs: &[[f32; 2]]) -> Vec<[f32; 4]> {
    let clean3 = |v: &[[f32; 3]]| v.iter().map(|p| if p.iter().all(|c| c.is_finite()) { *p } else { [0.0; 3] }).collect::<Vec<_>>();
    let positions = clean3(positions);
    let normals = clean3(normals);
    let uvs: Vec<[f32; 2]> = uvs.iter().map(|p| if p.iter().all(|c| c.is_finite()) { *p } else { [0.0; 2] }).collect();
    let mut primitive = Primitive { indices, positions: &positions, normals: &normals, uvs: &uvs, out: vec![[0.0; 4]; indices.len()] };
    // The port is safe Rust and returns no errors; a panic inside it would
    // still be a bug of ours to report, not a reason to take the renderer down.
    let ok = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| generate_tangents(&mut primitive).is_ok())).unwrap_or(false);
    if ok { primitive.out } else { vec![[0.0; 4]; indices.len()] }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quad in the XY plane facing +Z with u along +X and v along −Y
    /// (glTF's v runs down the image): the tangent is +X, and the
    /// bitangent sign makes B = sign·(N × T) point along +v, i.e. −Y.
    #[test]
    fn tangent_follows_u_and_the_sign_follows_v() {
        let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let normals = [[0.0, 0.0, 1.0]; 4];
        let uvs = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
        let t = mikktspace(&[0, 1, 2, 0, 2, 3], &positions, &normals, &uvs);
        for c in &t {
            assert!((c[0] - 1.0).abs() < 1e-5 && c[1].abs() < 1e-5 && c[2].abs() < 1e-5, "{c:?}");
            assert_eq!(c[3], -1.0, "N × T = +Y is against +v's direction (−Y): {c:?}");
        }
        // Mirrored UVs flip the sign.
        let mirrored = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let t = mikktspace(&[0, 1, 2, 0, 2, 3], &positions, &normals, &mirrored);
        assert!(t.iter().all(|c| c[3] == 1.0), "{t:?}");
    }

    #[test]
    fn degenerate_and_broken_input_gives_finite_tangents() {
        let positions = [[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 0.0, 0.0]];
        let t = mikktspace(&[0, 1, 2, 0, 0, 0], &positions, &[[0.0; 3]; 3], &[[f32::INFINITY, 0.0]; 3]);
        assert_eq!(t.len(), 6);
        assert!(t.iter().flatten().all(|v| v.is_finite()));
    }
}
