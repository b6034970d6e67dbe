//! Colour conversions: sRGB transfer curve, linear RGB → CIELab (D65), luminance.

/// sRGB-encoded value in [0, 1] to linear light.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light to sRGB encoding; the input is clamped to [0, 1].
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Relative luminance Y of a linear Rec.709/sRGB pixel (computed in f64 and clamped to the
/// f32 range, so extreme inputs cannot overflow to infinity).
pub fn luminance(p: [f32; 3]) -> f32 {
    let y = 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
    y.clamp(-(f32::MAX as f64), f32::MAX as f64) as f32
}

fn lab_f(t: f64) -> f64 {
    const D: f64 = 6.0 / 29.0;
    if t > D * D * D {
        t.cbrt()
    } else {
        t / (3.0 * D * D) + 4.0 / 29.0
    }
}

/// Linear sRGB (D65, white = 1) to CIELab (L* in [0, 100]); computed in f64 so that extreme
/// inputs stay finite.
pub fn linear_to_lab(p: [f32; 3]) -> [f32; 3] {
    let [r, g, b] = p.map(|v| v.max(0.0) as f64);
    let x = (0.412_456_4 * r + 0.357_576_1 * g + 0.180_437_5 * b) / 0.950_47;
    let y = 0.212_672_9 * r + 0.715_152_2 * g + 0.072_175 * b;
    let z = (0.019_333_9 * r + 0.119_192 * g + 0.950_304_1 * b) / 1.088_83;
    let (fx, fy, fz) = (lab_f(x), lab_f(y), lab_f(z));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)].map(|v| v as f32)
}

/// RGB in [0, 1] to (hue in degrees [0, 360), saturation, value).
pub fn rgb_to_hsv(p: [f32; 3]) -> [f32; 3] {
    let [r, g, b] = p;
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let d = max - min;
    let h = if d <= 0.0 {
        0.0
    } else if max == r {
        60.0 * ((g - b) / d).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / d + 2.0)
    } else {
        60.0 * ((r - g) / d + 4.0)
    };
    let s = if max <= 0.0 { 0.0 } else { d / max };
    [h, s, max]
}

/// (hue in degrees, saturation, value) to RGB.
pub fn hsv_to_rgb(p: [f32; 3]) -> [f32; 3] {
    let [h, s, v] = p;
    let h = h.rem_euclid(360.0) / 60.0;
    let c = v * s;
    let x = c * (1.0 - (h.rem_euclid(2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r + m, g + m, b + m]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip() {
        for i in 0..=100 {
            let v = i as f32 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(v)) - v).abs() < 1e-5);
        }
    }

    #[test]
    fn lab_of_white_and_grey() {
        let w = linear_to_lab([1.0, 1.0, 1.0]);
        assert!((w[0] - 100.0).abs() < 0.01 && w[1].abs() < 0.01 && w[2].abs() < 0.01);
        let g = linear_to_lab([0.18, 0.18, 0.18]);
        assert!((g[0] - 49.5).abs() < 0.2, "{g:?}");
        let red = linear_to_lab([1.0, 0.0, 0.0]);
        assert!(
            (red[0] - 53.24).abs() < 0.1 && (red[1] - 80.09).abs() < 0.2,
            "{red:?}"
        );
    }

    #[test]
    fn hsv_round_trip() {
        let p = [0.2, 0.7, 0.4];
        let q = hsv_to_rgb(rgb_to_hsv(p));
        for c in 0..3 {
            assert!((p[c] - q[c]).abs() < 1e-5);
        }
    }
}
