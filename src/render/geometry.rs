//! Ray intersection: spheres, boxes, planes and triangle meshes (with a median-split BVH), and a
//! small OBJ reader.
//!
//! Every shape is intersected in its own object space: the caller moves the ray by the object's
//! inverse transform (the direction is not renormalised, so the ray parameter `t` is the same in
//! both spaces).

use glam::Vec3;
use std::path::Path;

/// A ray `origin + t · direction`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
}

impl Ray {
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }
}

/// A hit in object space: the ray parameter and the geometric and shading normals (not
/// normalised, not necessarily facing the ray).
#[derive(Clone, Copy, Debug)]
pub struct LocalHit {
    pub t: f32,
    /// The hit point, on the surface (a box's face coordinate and a plane's y are exact, so a
    /// texture with a boundary there does not speckle).
    pub point: Vec3,
    pub geometric_normal: Vec3,
    pub shading_normal: Vec3,
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(self, other: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// Entry and exit parameters of the ray within `(t_min, t_max)`, or `None` (slab test; a
    /// zero direction component gives ±infinity, which the min/max order handles).
    #[inline]
    pub fn clip(&self, origin: Vec3, inv_dir: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let t0 = (self.min - origin) * inv_dir;
        let t1 = (self.max - origin) * inv_dir;
        let near = t0.min(t1);
        let far = t0.max(t1);
        // NaN (0 · inf, a ray in a slab's plane) compares false: treat it as no constraint.
        let enter = near.max_element().max(t_min);
        let exit = far.min_element().min(t_max);
        (enter <= exit).then_some((enter, exit))
    }
}

/// Sphere of `radius` around the origin.
pub fn intersect_sphere(radius: f32, ray: &Ray, t_min: f32, t_max: f32) -> Option<LocalHit> {
    let (o, d) = (ray.origin, ray.direction);
    let a = d.length_squared();
    let half_b = o.dot(d);
    let c = o.length_squared() - radius * radius;
    let disc = half_b * half_b - a * c;
    if disc < 0.0 || a == 0.0 {
        return None;
    }
    let root = disc.sqrt();
    // The numerically stable pair of roots.
    let q = -(half_b + root.copysign(half_b));
    let (mut t0, mut t1) = (q / a, if q != 0.0 { c / q } else { q / a });
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    let t = if t0 > t_min && t0 < t_max {
        t0
    } else if t1 > t_min && t1 < t_max {
        t1
    } else {
        return None;
    };
    let n = ray.at(t);
    Some(LocalHit {
        t,
        point: n,
        geometric_normal: n,
        shading_normal: n,
    })
}

/// Box from `-half` to `half`.
pub fn intersect_box(half: Vec3, ray: &Ray, t_min: f32, t_max: f32) -> Option<LocalHit> {
    let inv = ray.direction.recip();
    let t0 = (-half - ray.origin) * inv;
    let t1 = (half - ray.origin) * inv;
    let near = t0.min(t1);
    let far = t0.max(t1);
    let enter = near.max_element();
    let exit = far.min_element();
    if enter > exit {
        return None;
    }
    let t = if enter > t_min && enter < t_max {
        enter
    } else if exit > t_min && exit < t_max {
        exit
    } else {
        return None;
    };
    // The face hit is the axis where the point is closest to the box's surface, relative to
    // the box's size.
    let mut point = ray.at(t);
    let p = point / half;
    let a = p.abs();
    let n = if a.x >= a.y && a.x >= a.z {
        point.x = half.x.copysign(p.x);
        Vec3::new(p.x.signum(), 0.0, 0.0)
    } else if a.y >= a.z {
        point.y = half.y.copysign(p.y);
        Vec3::new(0.0, p.y.signum(), 0.0)
    } else {
        point.z = half.z.copysign(p.z);
        Vec3::new(0.0, 0.0, p.z.signum())
    };
    Some(LocalHit {
        t,
        point: point.clamp(-half, half),
        geometric_normal: n,
        shading_normal: n,
    })
}

/// The plane y = 0, infinite or limited to `|x| <= size[0] / 2`, `|z| <= size[1] / 2`.
pub fn intersect_plane(
    size: Option<[f32; 2]>,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<LocalHit> {
    if ray.direction.y == 0.0 {
        return None;
    }
    let t = -ray.origin.y / ray.direction.y;
    if !(t > t_min && t < t_max) {
        return None;
    }
    let mut point = ray.at(t);
    point.y = 0.0;
    if let Some([w, d]) = size {
        if point.x.abs() > w * 0.5 || point.z.abs() > d * 0.5 {
            return None;
        }
    }
    Some(LocalHit {
        t,
        point,
        geometric_normal: Vec3::Y,
        shading_normal: Vec3::Y,
    })
}

/// One triangle as read or tessellated: positions and optional vertex normals.
#[derive(Clone, Copy, Debug)]
pub struct MeshTriangle {
    pub positions: [Vec3; 3],
    pub normals: Option<[Vec3; 3]>,
}

/// A triangle prepared for Möller–Trumbore.
#[derive(Clone, Copy, Debug)]
struct Tri {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
}

#[derive(Clone, Copy, Debug)]
struct BvhNode {
    bounds: Aabb,
    /// Leaf: first triangle; inner node: index of the second child (the first follows this
    /// node).
    index: u32,
    /// Triangles in a leaf; 0 for an inner node.
    count: u32,
}

/// Triangles in a leaf at most.
const LEAF_SIZE: usize = 4;
/// Deepest BVH the traversal stack holds; a median split halves the triangles at each level,
/// so 64 levels are never reached.
const MAX_DEPTH: usize = 64;

/// A triangle mesh with a bounding volume hierarchy (median split on the widest centroid axis).
#[derive(Debug)]
pub struct Mesh {
    tris: Vec<Tri>,
    normals: Vec<Option<[Vec3; 3]>>,
    nodes: Vec<BvhNode>,
}

impl Mesh {
    /// Builds the BVH. Triangles with non-finite coordinates are dropped.
    pub fn new(triangles: Vec<MeshTriangle>) -> Mesh {
        let mut triangles: Vec<MeshTriangle> = triangles
            .into_iter()
            .filter(|t| t.positions.iter().all(|p| p.is_finite()))
            .collect();
        let mut nodes = Vec::with_capacity(2 * triangles.len() / LEAF_SIZE + 1);
        if !triangles.is_empty() {
            let centroids: Vec<Vec3> = triangles
                .iter()
                .map(|t| (t.positions[0] + t.positions[1] + t.positions[2]) / 3.0)
                .collect();
            let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
            build(&triangles, &centroids, &mut order, &mut nodes);
            let sorted: Vec<MeshTriangle> = order.iter().map(|&i| triangles[i as usize]).collect();
            triangles = sorted;
        }
        Mesh {
            tris: triangles
                .iter()
                .map(|t| Tri {
                    v0: t.positions[0],
                    e1: t.positions[1] - t.positions[0],
                    e2: t.positions[2] - t.positions[0],
                })
                .collect(),
            normals: triangles.iter().map(|t| t.normals).collect(),
            nodes,
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// The bounding box (min, max); both zero for an empty mesh.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self.nodes.first() {
            Some(n) => (n.bounds.min, n.bounds.max),
            None => (Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// The mesh centred on the origin and scaled (uniformly) to fit in [-1, 1]^3.
    pub fn fitted(&self) -> Mesh {
        let (lo, hi) = self.bounds();
        let centre = (lo + hi) * 0.5;
        let half = ((hi - lo) * 0.5).max_element();
        let scale = if half > 0.0 && half.is_finite() {
            1.0 / half
        } else {
            1.0
        };
        let triangles = self
            .tris
            .iter()
            .zip(&self.normals)
            .map(|(t, n)| MeshTriangle {
                positions: [t.v0, t.v0 + t.e1, t.v0 + t.e2].map(|p| (p - centre) * scale),
                normals: *n,
            })
            .collect();
        Mesh::new(triangles)
    }

    /// The nearest hit within `(t_min, t_max)`.
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<LocalHit> {
        let mut best: Option<(f32, usize, f32, f32)> = None;
        let mut limit = t_max;
        self.traverse(ray, t_min, &mut limit, |tri, t, u, v| {
            best = Some((t, tri, u, v));
            false
        });
        let (t, index, u, v) = best?;
        let tri = &self.tris[index];
        let geometric = tri.e1.cross(tri.e2);
        let shading = match self.normals[index] {
            Some([n0, n1, n2]) => {
                let n = n0 * (1.0 - u - v) + n1 * u + n2 * v;
                if n.length_squared() > 0.0 {
                    n
                } else {
                    geometric
                }
            }
            None => geometric,
        };
        Some(LocalHit {
            t,
            point: ray.at(t),
            geometric_normal: geometric,
            shading_normal: shading,
        })
    }

    /// Whether anything lies within `(t_min, t_max)` (shadow rays: stops at the first hit).
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        let mut hit = false;
        let mut limit = t_max;
        self.traverse(ray, t_min, &mut limit, |_, _, _, _| {
            hit = true;
            true
        });
        hit
    }

    /// Visits triangle hits nearer than `*limit` (which shrinks to each hit); `on_hit` returns
    /// true to stop.
    fn traverse(
        &self,
        ray: &Ray,
        t_min: f32,
        limit: &mut f32,
        mut on_hit: impl FnMut(usize, f32, f32, f32) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = ray.direction.recip();
        let mut stack = [0u32; MAX_DEPTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.bounds.clip(ray.origin, inv, t_min, *limit).is_none() {
                continue;
            }
            if node.count > 0 {
                let first = node.index as usize;
                for i in first..first + node.count as usize {
                    if let Some((t, u, v)) = intersect_tri(&self.tris[i], ray, t_min, *limit) {
                        *limit = t;
                        if on_hit(i, t, u, v) {
                            return;
                        }
                    }
                }
            } else if top + 2 <= MAX_DEPTH {
                let here = stack[top];
                stack[top] = node.index;
                stack[top + 1] = here + 1;
                top += 2;
            }
        }
    }
}

/// Builds the subtree over `order` (indices into `tris`) and returns its node index. Recursion
/// depth is bounded by log2 of the triangle count (median split).
fn build(tris: &[MeshTriangle], centroids: &[Vec3], order: &mut [u32], nodes: &mut Vec<BvhNode>) {
    fn go(
        tris: &[MeshTriangle],
        centroids: &[Vec3],
        order: &mut [u32],
        offset: usize,
        nodes: &mut Vec<BvhNode>,
    ) {
        let mut bounds = Aabb::EMPTY;
        let mut centre_bounds = Aabb::EMPTY;
        for &i in order.iter() {
            for p in tris[i as usize].positions {
                bounds.grow(p);
            }
            centre_bounds.grow(centroids[i as usize]);
        }
        let me = nodes.len();
        nodes.push(BvhNode {
            bounds,
            index: offset as u32,
            count: order.len() as u32,
        });
        if order.len() <= LEAF_SIZE {
            return;
        }
        let extent = centre_bounds.max - centre_bounds.min;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&a, &b| {
            let (ca, cb) = (centroids[a as usize][axis], centroids[b as usize][axis]);
            ca.total_cmp(&cb).then(a.cmp(&b))
        });
        let (left, right) = order.split_at_mut(mid);
        go(tris, centroids, left, offset, nodes);
        let second = nodes.len();
        go(tris, centroids, right, offset + mid, nodes);
        nodes[me].index = second as u32;
        nodes[me].count = 0;
    }
    go(tris, centroids, order, 0, nodes);
}

/// Möller–Trumbore; returns (t, u, v).
#[inline]
fn intersect_tri(tri: &Tri, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
    let p = ray.direction.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = ray.origin - tri.v0;
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(tri.e1);
    let v = ray.direction.dot(q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = tri.e2.dot(q) * inv_det;
    (t > t_min && t < t_max).then_some((t, u, v))
}

/// Most triangles an OBJ file may give (polygons count as their fan's triangles).
pub const MAX_OBJ_TRIANGLES: usize = 20_000_000;

/// An OBJ problem at a 1-based line and column.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjError {
    pub line: usize,
    pub column: usize,
    pub message: String,
}

/// Reads the geometry of a Wavefront OBJ text: `v` (x y z, an optional w ignored), `vn`, and
/// `f` with any number (≥ 3) of corners `v`, `v/vt`, `v//vn` or `v/vt/vn`, indices 1-based or
/// negative (relative to the end). Polygons are split into a fan. Texture coordinates, groups,
/// smoothing groups and materials are ignored. Faces whose corners all carry normals get them;
/// the others are shaded flat.
pub fn parse_obj(text: &str) -> Result<Vec<MeshTriangle>, ObjError> {
    let mut positions: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut triangles = Vec::new();
    for (line_index, raw_line) in text.lines().enumerate() {
        let line_no = line_index + 1;
        let content = raw_line.split('#').next().unwrap_or("");
        let mut words = words_with_columns(content);
        let Some((_, keyword)) = words.next() else {
            continue;
        };
        let error = |column: usize, message: String| ObjError {
            line: line_no,
            column,
            message,
        };
        match keyword {
            "v" | "vn" => {
                let mut xyz = [0.0f32; 3];
                for (k, c) in xyz.iter_mut().enumerate() {
                    let Some((col, word)) = words.next() else {
                        return Err(error(
                            raw_line.len() + 1,
                            format!("`{keyword}` needs 3 numbers, found {k}"),
                        ));
                    };
                    *c = match word.parse::<f32>() {
                        Ok(v) if v.is_finite() => v,
                        _ => return Err(error(col, format!("`{word}` is not a finite number"))),
                    };
                }
                if keyword == "v" {
                    positions.push(Vec3::from(xyz));
                } else {
                    normals.push(Vec3::from(xyz));
                }
            }
            "f" => {
                let mut corners: Vec<(Vec3, Option<Vec3>)> = Vec::new();
                for (col, word) in words {
                    let mut parts = word.split('/');
                    let v = parts.next().unwrap_or("");
                    let _vt = parts.next();
                    let vn = parts.next().filter(|s| !s.is_empty());
                    let p = resolve(v, positions.len(), "vertex").map_err(|m| error(col, m))?;
                    let n = match vn {
                        Some(vn) => Some(
                            normals[resolve(vn, normals.len(), "normal")
                                .map_err(|m| error(col, m))?],
                        ),
                        None => None,
                    };
                    corners.push((positions[p], n));
                }
                if corners.len() < 3 {
                    return Err(error(
                        1,
                        format!("a face needs at least 3 corners, found {}", corners.len()),
                    ));
                }
                if triangles.len() + corners.len() - 2 > MAX_OBJ_TRIANGLES {
                    return Err(error(
                        1,
                        format!("more than {MAX_OBJ_TRIANGLES} triangles, the limit for meshes"),
                    ));
                }
                let with_normals = corners.iter().all(|c| c.1.is_some());
                for k in 1..corners.len() - 1 {
                    let tri = [corners[0], corners[k], corners[k + 1]];
                    triangles.push(MeshTriangle {
                        positions: tri.map(|c| c.0),
                        normals: with_normals.then(|| tri.map(|c| c.1.unwrap_or(Vec3::ZERO))),
                    });
                }
            }
            _ => {} // vt, o, g, s, usemtl, mtllib, l, p, ...: not needed for a preview
        }
    }
    Ok(triangles)
}

/// Words of a line with their 1-based columns.
fn words_with_columns(line: &str) -> impl Iterator<Item = (usize, &str)> {
    line.split_whitespace().map(move |w| {
        let start = w.as_ptr() as usize - line.as_ptr() as usize;
        (line[..start].chars().count() + 1, w)
    })
}

/// An OBJ index (1-based, or negative from the end) into a list of `len` items.
fn resolve(word: &str, len: usize, what: &str) -> Result<usize, String> {
    let plural = match (what, len) {
        (_, 1) => what.to_string(),
        ("vertex", _) => "vertices".to_string(),
        _ => format!("{what}s"),
    };
    let index: i64 = word
        .parse()
        .map_err(|_| format!("`{word}` is not a {what} index"))?;
    let resolved = if index > 0 {
        index - 1
    } else if index < 0 {
        len as i64 + index
    } else {
        return Err(format!("{what} index 0: OBJ indices start at 1"));
    };
    if resolved < 0 || resolved >= len as i64 {
        return Err(format!(
            "{what} index {index} is out of range: {len} {plural} so far"
        ));
    }
    Ok(resolved as usize)
}

/// Reads an OBJ file (see [`parse_obj`]).
pub fn load_obj(path: &Path) -> std::io::Result<Result<Vec<MeshTriangle>, ObjError>> {
    let text = std::fs::read_to_string(path)?;
    Ok(parse_obj(&text))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_messages_count_in_plain_english() {
        assert_eq!(
            resolve("3", 2, "vertex").unwrap_err(),
            "vertex index 3 is out of range: 2 vertices so far"
        );
        assert_eq!(
            resolve("2", 1, "vertex").unwrap_err(),
            "vertex index 2 is out of range: 1 vertex so far"
        );
        assert_eq!(
            resolve("-4", 3, "normal").unwrap_err(),
            "normal index -4 is out of range: 3 normals so far"
        );
    }

    fn ray(o: [f32; 3], d: [f32; 3]) -> Ray {
        Ray {
            origin: Vec3::from(o),
            direction: Vec3::from(d),
        }
    }

    #[test]
    fn sphere_box_plane_hits() {
        let r = ray([0.0, 0.0, 5.0], [0.0, 0.0, -1.0]);
        let h = intersect_sphere(1.0, &r, 1e-4, f32::INFINITY).unwrap();
        assert!((h.t - 4.0).abs() < 1e-5);
        assert!(
            intersect_sphere(1.0, &ray([0.0, 2.0, 5.0], [0.0, 0.0, -1.0]), 0.0, 100.0).is_none()
        );
        // From inside: the far side.
        let h = intersect_sphere(1.0, &ray([0.0; 3], [1.0, 0.0, 0.0]), 1e-4, 100.0).unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);

        let h = intersect_box(Vec3::new(1.0, 2.0, 3.0), &r, 1e-4, 100.0).unwrap();
        assert!((h.t - 2.0).abs() < 1e-5);
        assert_eq!(h.geometric_normal, Vec3::Z);
        let h = intersect_box(
            Vec3::ONE,
            &ray([0.0, 5.0, 0.0], [0.0, -1.0, 0.0]),
            1e-4,
            100.0,
        )
        .unwrap();
        assert_eq!(h.geometric_normal, Vec3::Y);

        let h =
            intersect_plane(None, &ray([0.0, 1.0, 0.0], [0.0, -1.0, 1.0]), 1e-4, 100.0).unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!(intersect_plane(
            Some([1.0, 1.0]),
            &ray([0.0, 1.0, 0.0], [0.0, -1.0, 1.0]),
            1e-4,
            100.0
        )
        .is_none());
        assert!(
            intersect_plane(None, &ray([0.0, 1.0, 0.0], [0.0, 1.0, 0.0]), 1e-4, 100.0).is_none()
        );
    }

    #[test]
    fn obj_faces_polygons_and_index_forms() {
        let text =
            "# a unit quad and a triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
                    f 1 2 3 4\nf 1/1/1 2/1/1 3/1/1\nf -4//1 -3//1 -2//1\ng ignored\nusemtl x\n";
        let tris = parse_obj(text).unwrap();
        assert_eq!(tris.len(), 4);
        assert!(tris[0].normals.is_none());
        assert_eq!(tris[2].normals.unwrap()[0], Vec3::Z);
        assert_eq!(tris[3].positions[2], Vec3::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn obj_errors_name_line_and_column() {
        let e = parse_obj("v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap_err();
        assert_eq!((e.line, e.column), (3, 7));
        assert!(e.message.contains("out of range"), "{}", e.message);
        let e = parse_obj("v 0 zero 0\n").unwrap_err();
        assert_eq!((e.line, e.column), (1, 5));
        let e = parse_obj("v 0 0\n").unwrap_err();
        assert!(e.message.contains("needs 3 numbers"));
        let e = parse_obj("v 0 0 0\nf 1 1\n").unwrap_err();
        assert!(e.message.contains("at least 3"));
        let e = parse_obj("v 0 0 0\nf 0 1 1\n").unwrap_err();
        assert!(e.message.contains("start at 1"));
    }

    #[test]
    fn bvh_agrees_with_brute_force() {
        // A grid of small triangles at varying depths.
        let mut tris = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                let o = Vec3::new(
                    i as f32 * 0.1,
                    j as f32 * 0.1,
                    ((i * 7 + j * 3) % 11) as f32 * 0.05,
                );
                tris.push(MeshTriangle {
                    positions: [
                        o,
                        o + Vec3::new(0.12, 0.0, 0.0),
                        o + Vec3::new(0.0, 0.12, 0.01),
                    ],
                    normals: None,
                });
            }
        }
        let mesh = Mesh::new(tris.clone());
        let mut state = 12345u64;
        let mut rand = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        for _ in 0..2000 {
            let r = ray(
                [rand() * 4.0, rand() * 4.0, 3.0],
                [rand() - 0.5, rand() - 0.5, -1.0],
            );
            let brute = tris
                .iter()
                .filter_map(|t| {
                    let tri = Tri {
                        v0: t.positions[0],
                        e1: t.positions[1] - t.positions[0],
                        e2: t.positions[2] - t.positions[0],
                    };
                    intersect_tri(&tri, &r, 1e-4, f32::INFINITY).map(|h| h.0)
                })
                .fold(f32::INFINITY, f32::min);
            let bvh = mesh
                .intersect(&r, 1e-4, f32::INFINITY)
                .map_or(f32::INFINITY, |h| h.t);
            assert_eq!(brute, bvh);
            assert_eq!(brute.is_finite(), mesh.occluded(&r, 1e-4, f32::INFINITY));
        }
    }
}
