// lattice.wgsl: the lattice bases' values (noise/perlin.rs, gradient.rs, value.rs): Perlin's
// improved noise (2002 reference order), Ebert's gradient noise, value noise (linear and
// smoothstep weights) and white noise, each plain and tiled. The corner hashes take the lower
// and upper index per axis, so the tiled forms are the plain ones with the upper corner
// wrapped to cell 0 in a period's last cell (noise/period.rs).

fn lerp1(t: f32, a: f32, b: f32) -> f32 {
    return a + t * (b - a);
}

// Ebert's SMOOTHSTEP(t) = t t (3 - 2 t).
fn ease_smooth(t: f32) -> f32 {
    return t * t * (3.0 - 2.0 * t);
}

// Perlin's fade(t) = t^3 (t (6 t - 15) + 10), in the reference's association order.
fn ease_fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

// Perlin's hash of a corner: p[p[p[x] + y] + z].
fn hash_perlin(t: u32, x: u32, y: u32, z: u32) -> u32 {
    return perm_at(t, perm_at(t, perm_at(t, x) + y) + z);
}

// Ebert's INDEX(x, y, z) = PERM(x + PERM(y + PERM(z))).
fn hash_ebert(t: u32, x: u32, y: u32, z: u32) -> u32 {
    return perm_at(t, x + perm_at(t, y + perm_at(t, z)));
}

// The reference's grad: the low 4 hash bits pick u, v and their signs; one addition.
fn perlin_corner(hash: u32, x: f32, y: f32, z: f32) -> f32 {
    let h = hash & 15u;
    var u = y;
    if (h < 8u) {
        u = x;
    }
    var v = z;
    if (h < 4u) {
        v = y;
    } else if (h == 12u || h == 14u) {
        v = x;
    }
    if ((h & 1u) != 0u) {
        u = -u;
    }
    if ((h & 2u) != 0u) {
        return u - v;
    }
    return u + v;
}

fn perlin_interior(t: u32, lo: vec3<u32>, hi: vec3<u32>, f: vec3<f32>) -> f32 {
    let x = f.x;
    let y = f.y;
    let z = f.z;
    let u = ease_fade(x);
    let v = ease_fade(y);
    let w = ease_fade(z);
    let x1 = x - 1.0;
    let y1 = y - 1.0;
    let z1 = z - 1.0;
    let c000 = perlin_corner(hash_perlin(t, lo.x, lo.y, lo.z), x, y, z);
    let c100 = perlin_corner(hash_perlin(t, hi.x, lo.y, lo.z), x1, y, z);
    let c010 = perlin_corner(hash_perlin(t, lo.x, hi.y, lo.z), x, y1, z);
    let c110 = perlin_corner(hash_perlin(t, hi.x, hi.y, lo.z), x1, y1, z);
    let c001 = perlin_corner(hash_perlin(t, lo.x, lo.y, hi.z), x, y, z1);
    let c101 = perlin_corner(hash_perlin(t, hi.x, lo.y, hi.z), x1, y, z1);
    let c011 = perlin_corner(hash_perlin(t, lo.x, hi.y, hi.z), x, y1, z1);
    let c111 = perlin_corner(hash_perlin(t, hi.x, hi.y, hi.z), x1, y1, z1);
    return lerp1(w,
        lerp1(v, lerp1(u, c000, c100), lerp1(u, c010, c110)),
        lerp1(v, lerp1(u, c001, c101), lerp1(u, c011, c111)));
}

fn gradient_dot(t: u32, h: u32, x: f32, y: f32, z: f32) -> f32 {
    let g = grad_at(t, h);
    return g.x * x + g.y * y + g.z * z;
}

fn gradient_interior(t: u32, lo: vec3<u32>, hi: vec3<u32>, f: vec3<f32>) -> f32 {
    let f1 = f - vec3<f32>(1.0);
    let wx = ease_smooth(f.x);
    let wy = ease_smooth(f.y);
    let wz = ease_smooth(f.z);
    let a0 = lerp1(wx, gradient_dot(t, hash_ebert(t, lo.x, lo.y, lo.z), f.x, f.y, f.z),
                       gradient_dot(t, hash_ebert(t, hi.x, lo.y, lo.z), f1.x, f.y, f.z));
    let a1 = lerp1(wx, gradient_dot(t, hash_ebert(t, lo.x, hi.y, lo.z), f.x, f1.y, f.z),
                       gradient_dot(t, hash_ebert(t, hi.x, hi.y, lo.z), f1.x, f1.y, f.z));
    let b0 = lerp1(wx, gradient_dot(t, hash_ebert(t, lo.x, lo.y, hi.z), f.x, f.y, f1.z),
                       gradient_dot(t, hash_ebert(t, hi.x, lo.y, hi.z), f1.x, f.y, f1.z));
    let b1 = lerp1(wx, gradient_dot(t, hash_ebert(t, lo.x, hi.y, hi.z), f.x, f1.y, f1.z),
                       gradient_dot(t, hash_ebert(t, hi.x, hi.y, hi.z), f1.x, f1.y, f1.z));
    return lerp1(wz, lerp1(wy, a0, a1), lerp1(wy, b0, b1));
}

fn value_interior(t: u32, lo: vec3<u32>, hi: vec3<u32>, w: vec3<f32>) -> f32 {
    let a0 = lerp1(w.x, value_at(t, hash_ebert(t, lo.x, lo.y, lo.z)), value_at(t, hash_ebert(t, hi.x, lo.y, lo.z)));
    let a1 = lerp1(w.x, value_at(t, hash_ebert(t, lo.x, hi.y, lo.z)), value_at(t, hash_ebert(t, hi.x, hi.y, lo.z)));
    let b0 = lerp1(w.x, value_at(t, hash_ebert(t, lo.x, lo.y, hi.z)), value_at(t, hash_ebert(t, hi.x, lo.y, hi.z)));
    let b1 = lerp1(w.x, value_at(t, hash_ebert(t, lo.x, hi.y, hi.z)), value_at(t, hash_ebert(t, hi.x, hi.y, hi.z)));
    return lerp1(w.z, lerp1(w.y, a0, a1), lerp1(w.y, b0, b1));
}

fn upper_plain(s: Split3) -> vec3<u32> {
    return (s.index + vec3<u32>(1u)) & vec3<u32>(255u);
}

fn perlin_sample(t: u32, p: vec3<f64>) -> f32 {
    let s = lattice3(p);
    return perlin_interior(t, s.index, upper_plain(s), s.frac);
}

fn perlin_sample_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> f32 {
    let r = reduce3(p, period);
    let s = lattice3(r.p);
    return perlin_interior(t, s.index, upper_index(s, r.wrap), s.frac);
}

fn gradient_sample(t: u32, p: vec3<f64>) -> f32 {
    let s = lattice3(p);
    return gradient_interior(t, s.index, upper_plain(s), s.frac);
}

fn gradient_sample_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> f32 {
    let r = reduce3(p, period);
    let s = lattice3(r.p);
    return gradient_interior(t, s.index, upper_index(s, r.wrap), s.frac);
}

fn value_linear_sample(t: u32, p: vec3<f64>) -> f32 {
    let s = lattice3(p);
    return value_interior(t, s.index, upper_plain(s), s.frac);
}

fn value_linear_sample_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> f32 {
    let r = reduce3(p, period);
    let s = lattice3(r.p);
    return value_interior(t, s.index, upper_index(s, r.wrap), s.frac);
}

fn value_smooth_sample(t: u32, p: vec3<f64>) -> f32 {
    let s = lattice3(p);
    let w = vec3<f32>(ease_smooth(s.frac.x), ease_smooth(s.frac.y), ease_smooth(s.frac.z));
    return value_interior(t, s.index, upper_plain(s), w);
}

fn value_smooth_sample_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> f32 {
    let r = reduce3(p, period);
    let s = lattice3(r.p);
    let w = vec3<f32>(ease_smooth(s.frac.x), ease_smooth(s.frac.y), ease_smooth(s.frac.z));
    return value_interior(t, s.index, upper_index(s, r.wrap), w);
}

// White noise (value.rs `white`): the hash value of the point's cell (noise/hash.rs); NaN for a
// non-finite point.
fn white_sample(t: u32, p: vec3<f64>) -> f32 {
    let s = lattice3(p);
    if (is_nan3(s.frac)) {
        return nan_f32();
    }
    return hash_value(hash_cell(hash_key(t), floor(p)));
}

fn white_sample_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> f32 {
    return white_sample(t, reduce3(p, period).p);
}
