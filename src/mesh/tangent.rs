//! Tangent frames (MikkTSpace, the frame glTF viewers and Blender use) and the tangent-space
//! normal map of a height's exact gradient.
//!
//! MikkTSpace runs on the UVs with v upwards (u, 1 − v), as Blender does, so the bitangent
//! `B = w · (N × T)` points up the image, the glTF convention's +Y ("green up"); the same `w` is
//! what the GLB's `TANGENT` holds. A texel's frame is the per-corner frame interpolated as a
//! renderer interpolates vertex attributes (unnormalised, `B` from the interpolated `N` and
//! `T`), and the stored normal is the one that frame decodes to the bump normal exactly:
//! `t = [T B N]⁻¹ N'`, normalised (MikkTSpace's decoder normalises `t.x T + t.y B + t.z N`).

use super::model::Part;
use glam::{DMat3, DVec3};

/// Which way the green channel points: up (OpenGL, glTF, Blender) or down (DirectX).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum GreenAxis {
    #[default]
    Up,
    Down,
}

/// Per triangle corner of a part: MikkTSpace's tangent (xyz) and handedness (w = ±1).
pub fn corner_tangents(part: &Part) -> Vec<[[f32; 4]; 3]> {
    struct Geometry<'a> {
        part: &'a Part,
        out: Vec<[[f32; 4]; 3]>,
    }
    impl bevy_mikktspace::Geometry for Geometry<'_> {
        fn num_faces(&self) -> usize {
            self.part.triangles.len()
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            let i = self.part.triangles[face][vert] as usize;
            self.part.positions[i].map(|c| c as f32)
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            let i = self.part.triangles[face][vert] as usize;
            self.part.normals[i].map(|c| c as f32)
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            let i = self.part.triangles[face][vert] as usize;
            let [u, v] = self.part.uvs[i];
            [u as f32, (1.0 - v) as f32]
        }
        fn set_tangent(
            &mut self,
            tangent_space: Option<bevy_mikktspace::TangentSpace>,
            face: usize,
            vert: usize,
        ) {
            if let Some(space) = tangent_space {
                self.out[face][vert] = space.tangent_encoded();
            }
        }
    }
    let mut geometry = Geometry {
        part,
        out: vec![[[0.0; 4]; 3]; part.triangles.len()],
    };
    // The generator has no failure cases (its error type has no variants); a face it cannot
    // give a frame (degenerate UVs or positions) keeps the zero tangent, which `frame` replaces.
    let _ = bevy_mikktspace::generate_tangents(&mut geometry);
    for corner in geometry.out.iter_mut().flatten() {
        if corner[3] == 0.0 {
            corner[3] = 1.0;
        }
    }
    geometry.out
}

/// Any unit vector perpendicular to `n` (for frames MikkTSpace left without a tangent).
fn perpendicular(n: DVec3) -> DVec3 {
    let axis = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    (axis - n * n.dot(axis)).normalize_or(DVec3::X)
}

/// A texel's frame: the interpolated normal, tangent and bitangent (unnormalised, as a
/// renderer's fragment shader has them).
pub fn frame(normals: [DVec3; 3], tangents: [[f32; 4]; 3], bary: [f64; 3]) -> [DVec3; 3] {
    let n: DVec3 = (0..3).map(|k| normals[k] * bary[k]).sum();
    let mut t: DVec3 = (0..3)
        .map(|k| {
            DVec3::new(
                tangents[k][0].into(),
                tangents[k][1].into(),
                tangents[k][2].into(),
            ) * bary[k]
        })
        .sum();
    let w: f64 = (0..3).map(|k| f64::from(tangents[k][3]) * bary[k]).sum();
    let sign = if w < 0.0 { -1.0 } else { 1.0 };
    if t.cross(n).length_squared() < 1e-24 {
        t = perpendicular(n.normalize_or(DVec3::Z));
    }
    [t, n.cross(t) * sign, n]
}

/// The bump normal `normalize(N − s (∇h − (∇h·N) N))` of unit normal `n`, height gradient
/// `gradient` and strength `s`.
pub fn bump_normal(n: DVec3, gradient: DVec3, strength: f64) -> DVec3 {
    let surface = gradient - n * gradient.dot(n);
    (n - surface * strength).normalize_or(n)
}

/// The tangent-space normal stored for bump normal `bumped` in the frame `[t, b, n]`, as the
/// map's colour (components · 0.5 + 0.5), green flipped for [`GreenAxis::Down`].
pub fn encode(frame: [DVec3; 3], bumped: DVec3, green: GreenAxis) -> [f32; 3] {
    let matrix = DMat3::from_cols(frame[0], frame[1], frame[2]);
    let local = if matrix.determinant().abs() > 1e-300 {
        (matrix.inverse() * bumped).normalize_or(DVec3::Z)
    } else {
        DVec3::Z
    };
    let y = match green {
        GreenAxis::Up => local.y,
        GreenAxis::Down => -local.y,
    };
    [local.x, y, local.z].map(|c| (c * 0.5 + 0.5) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encoding_round_trips_through_the_decoder() {
        // A skewed, unnormalised frame: decoding t.x T + t.y B + t.z N gives back the bump
        // normal's direction.
        let frame = [
            DVec3::new(1.2, 0.1, -0.2),
            DVec3::new(0.3, 0.9, 0.1),
            DVec3::new(0.1, -0.2, 1.1),
        ];
        let bumped = DVec3::new(0.3, -0.4, 0.85).normalize();
        for green in [GreenAxis::Up, GreenAxis::Down] {
            let c = encode(frame, bumped, green).map(|v| f64::from(v) * 2.0 - 1.0);
            let y = if green == GreenAxis::Up { c[1] } else { -c[1] };
            let decoded = (frame[0] * c[0] + frame[1] * y + frame[2] * c[2]).normalize();
            assert!(decoded.angle_between(bumped) < 1e-6, "{green:?}");
        }
    }

    #[test]
    fn a_flat_height_keeps_the_normal() {
        let n = DVec3::new(0.0, 0.6, 0.8);
        assert!(bump_normal(n, n * 3.0, 1.0).angle_between(n) < 1e-12);
        let tilted = bump_normal(DVec3::Z, DVec3::new(1.0, 0.0, 0.0), 1.0);
        assert!((tilted - DVec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-12);
    }
}
