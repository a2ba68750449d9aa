//! Vector maths on `[f64; 3]` (mm or unitless), the one copy the planner
//! and the field model share. Axes and units are [`crate::units`]'.

/// A point or direction in space.
pub type Vec3 = [f64; 3];

/// A 3 × 3 matrix, row-major.
pub type Mat3 = [[f64; 3]; 3];

/// Dot product.
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a + b`.
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a − b`.
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `s · v`.
pub fn scale(v: Vec3, s: f64) -> Vec3 {
    [v[0] * s, v[1] * s, v[2] * s]
}

/// `a · x + y`.
pub fn axpy(a: f64, x: Vec3, y: Vec3) -> Vec3 {
    [a * x[0] + y[0], a * x[1] + y[1], a * x[2] + y[2]]
}

/// Euclidean length.
pub fn norm(v: Vec3) -> f64 {
    dot(v, v).sqrt()
}

/// Whether every component is finite.
pub fn is_finite(v: Vec3) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// `v / |v|`, or `None` when the length is zero or not finite.
pub fn normalized(v: Vec3) -> Option<Vec3> {
    let n = norm(v);
    (n.is_finite() && n > 0.0).then(|| v.map(|x| x / n))
}

/// Rotation matrix `Rz(z) · Ry(y) · Rx(x)` from angles in degrees.
pub fn euler_xyz_deg(deg: Vec3) -> Mat3 {
    let [x, y, z] = deg.map(f64::to_radians);
    let (sx, cx) = x.sin_cos();
    let (sy, cy) = y.sin_cos();
    let (sz, cz) = z.sin_cos();
    let rx = [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]];
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rz = [[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]];
    mat_mul(&rz, &mat_mul(&ry, &rx))
}

/// `a · b`.
pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// `m · v`.
pub fn mat_vec(m: &Mat3, v: Vec3) -> Vec3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_is_right_handed_and_orthogonal() {
        let (x, y) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert_eq!(cross(x, y), [0.0, 0.0, 1.0]);
        let (a, b) = ([1.0, 2.0, 3.0], [-4.0, 0.5, 2.0]);
        let c = cross(a, b);
        assert!(dot(a, c).abs() < 1e-12 && dot(b, c).abs() < 1e-12);
    }

    #[test]
    fn normalized_rejects_zero_and_non_finite() {
        assert_eq!(normalized([0.0; 3]), None);
        assert_eq!(normalized([f64::NAN, 0.0, 1.0]), None);
        assert_eq!(normalized([0.0, 3.0, 4.0]), Some([0.0, 0.6, 0.8]));
    }

    #[test]
    fn rotation_turns_x_into_y_about_z() {
        let r = euler_xyz_deg([0.0, 0.0, 90.0]);
        let v = mat_vec(&r, [1.0, 0.0, 0.0]);
        assert!(norm(sub(v, [0.0, 1.0, 0.0])) < 1e-12, "{v:?}");
        let id = mat_mul(&r, &euler_xyz_deg([0.0, 0.0, -90.0]));
        for (i, row) in id.iter().enumerate() {
            for (j, &x) in row.iter().enumerate() {
                assert!((x - f64::from(i == j)).abs() < 1e-12);
            }
        }
    }
}

/// Serde readers of fixed-size vectors in input files: exactly as many
/// numbers as the vector has. serde reads `[f64; 3]` as a tuple and the
/// TOML reader drops whatever follows the third element without a word, so
/// `center_mm = [0, 30, 30, 99]` would be taken as `[0, 30, 30]`.
pub mod exact {
    use serde::de::{Deserialize, Deserializer, Error};

    use super::Vec3;

    /// A `[f64; N]` field: `#[serde(deserialize_with = "geom::exact::array")]`.
    pub fn array<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        <[f64; N]>::try_from(v.as_slice())
            .map_err(|_| D::Error::invalid_length(v.len(), &format!("{N} numbers").as_str()))
    }

    /// A [`Vec3`] field: `#[serde(deserialize_with = "geom::exact::vec3")]`.
    pub fn vec3<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
        array(d)
    }

    /// An optional [`Vec3`] field (with `#[serde(default)]`).
    pub fn opt_vec3<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec3>, D::Error> {
        vec3(d).map(Some)
    }

    /// Three [`Vec3`] (a frame's axes), each exactly three numbers.
    pub fn axes<'de, D: Deserializer<'de>>(d: D) -> Result<[Vec3; 3], D::Error> {
        #[derive(serde::Deserialize)]
        #[serde(transparent)]
        struct Exact(#[serde(deserialize_with = "vec3")] Vec3);
        let v = Vec::<Exact>::deserialize(d)?;
        match v.as_slice() {
            [a, b, c] => Ok([a.0, b.0, c.0]),
            _ => Err(D::Error::invalid_length(v.len(), &"3 axes")),
        }
    }
}
