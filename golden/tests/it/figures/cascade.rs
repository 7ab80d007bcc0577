//! The cascade property: two Bartlett merges are the 7-tap tent, on
//! buffers and end to end through a render.

use super::*;

// --------------------------------------------- 4. the cascade property

fn grid(lo: i64, hi: i64) -> RayGrid {
    RayGrid {
        z_ref: 1.0,
        phi: [0.0; 2],
        lo: [lo; 2],
        hi: [hi; 2],
        slices: 0..0,
    }
}

fn at(buf: &[Rgba], g: &RayGrid, x: i64, y: i64) -> Rgba {
    let w = g.counts()[0];
    buf[(y - g.lo[1]) as usize * w + (x - g.lo[0]) as usize]
}

#[test]
fn two_bartlett_merges_are_the_7_tap_tent_in_2d() {
    // Adjoint form: the weight with which input ray (nx, ny) reaches output
    // ray (mx, my) after two merges is w(nx - 4 mx) w(ny - 4 my), the outer
    // product of (1 2 3 4 3 2 1) / 16 with itself, and 0 beyond.
    let (g0, g1, g2) = (grid(-8, 8), grid(-4, 4), grid(-2, 2));
    for ny in -8..=8 {
        for nx in -8..=8 {
            let mut buf = vec![[0f32; 4]; g0.len()];
            let w = g0.counts()[0];
            buf[(ny - g0.lo[1]) as usize * w + (nx - g0.lo[0]) as usize] = [1.0, 2.0, 3.0, 0.5];
            let b1 = merge(Merge::Bartlett, &buf, &g0, &g1);
            let b2 = merge(Merge::Bartlett, &b1, &g1, &g2);
            for my in -2..=2 {
                for mx in -2..=2 {
                    let want = cascade2(nx - 4 * mx) * cascade2(ny - 4 * my);
                    let got = at(&b2, &g2, mx, my);
                    for (c, scale) in [1.0, 2.0, 3.0, 0.5].into_iter().enumerate() {
                        assert!(
                            (got[c] as f64 - want * scale).abs() < 1e-7,
                            "input ({nx},{ny}) -> output ({mx},{my}) channel {c}: {} want {}",
                            got[c],
                            want * scale
                        );
                    }
                }
            }
        }
    }
    // Every input reaches the outputs with total weight 1/4 per axis (1/16):
    // the merge keeps sums over 4 (every 2nd ray per axis, taps summing to 1).
    for n in -5..=5i64 {
        let s: f64 = (-3..=3).map(|m| cascade2(n - 4 * m)).sum();
        assert!((s - 0.25).abs() < 1e-15);
    }
}

/// The impulse scene of the end-to-end cascade tests: 32^3, one voxel of
/// value 255 at (16, 16, `zv`), eye at (ex, ey, -D) looking along +z, so
/// view space is index space.
struct Impulse {
    d: f64,
    zv: usize,
    eye: DVec3,
    prep: Prepared,
}

const IMPULSE_N: usize = 32;

fn impulse_view(d: f64, zv: usize, ex: f64, ey: f64, cam_size: Option<(f64, u32)>) -> Impulse {
    let vol = volume([IMPULSE_N; 3], |x, y, z| {
        if (x, y, z) == (16, 16, zv) {
            255
        } else {
            0
        }
    });
    let eye = DVec3::new(ex, ey, -d);
    let look = DVec3::new(ex, ey, zv as f64);
    let (fov, size) = cam_size.unwrap_or((60.0, 8));
    let mut cam = camera(eye, look, DVec3::Y, fov, size, size);
    cam.image_plane = ImagePlane::Front;
    let prep = prepare(&vol, &cam);
    assert_eq!(prep.view.axes.label(), "+z");
    assert!((prep.view.d - d).abs() < 1e-12);
    Impulse { d, zv, eye, prep }
}

impl Impulse {
    /// Position on slice `zv` of the ray that meets the baseplane at `(u, v)`.
    fn at_voxel_slice(&self, u: f64, v: f64) -> (f64, f64) {
        let s = (self.zv as f64 + self.d) / self.d;
        (
            self.eye.x + (u - self.eye.x) * s,
            self.eye.y + (v - self.eye.y) * s,
        )
    }
    /// Path length per slice step of that ray.
    fn ds(&self, u: f64, v: f64) -> f64 {
        let (sx, sy) = ((u - self.eye.x) / self.d, (v - self.eye.y) / self.d);
        (1.0 + sx * sx + sy * sy).sqrt()
    }
}

fn hat(x: f64) -> f64 {
    (1.0 - x.abs()).max(0.0)
}

#[test]
fn two_merges_end_to_end_single_ray_shows_the_cascade() {
    // D = 6: bounds 0, 6, 18, 42, K = 3 for 32 slices; the impulse at slice
    // 24 lies in region 2, so its samples pass through exactly two merges
    // (2 -> 1 -> 0) before the baseplane.
    let (d, zv) = (6.0, 24usize);
    let regions = Regions::new(d, IMPULSE_N);
    assert_eq!(regions.count(), 3);
    assert!(regions.slices(2).contains(&zv));
    // Region 2's rays are one voxel apart on b_3 = 42 at integer positions,
    // so on slice 24 they are t2 = (24 + D) / (42 + D) = 5/8 apart and ray n
    // is at e + (n - e) t2. With e = 16 - delta, delta = r t2 / (1 - t2),
    // ray n = 16 + r passes exactly through the voxel (16, 16, 24).
    // A transfer function transparent below 250 makes only that ray see the
    // voxel (its neighbours, >= 1/2 voxel off, sample at most 255 / 2).
    let t2 = (zv as f64 + d) / (regions.bounds[3] + d);
    let l = lut(&tf(&[
        (0.0, [1.0, 1.0, 1.0, 0.0]),
        (250.0, [1.0, 1.0, 1.0, 0.0]),
        (255.0, [1.0, 1.0, 1.0, 1e-4]),
    ]));
    for (rx, ry) in [(0i64, 0i64), (1, 2), (2, 3), (3, 1)] {
        let delta = |r: i64| r as f64 * t2 / (1.0 - t2);
        let im = impulse_view(d, zv, 16.0 - delta(rx), 16.0 - delta(ry), None);
        let out = slice_render(Method::Er, &im.prep, &l, &opts(1.0, 1));
        assert_eq!(out.stats.merges, 2);
        let bp = &out.baseplane;
        let g = bp.grid;
        assert!(
            (g.spacing - 0.5).abs() < 1e-12,
            "baseplane samples half a voxel apart"
        );
        // The lit ray meets the baseplane where the line eye -> voxel does.
        let star = [
            im.eye.x + (16.0 - im.eye.x) * d / (zv as f64 + d),
            im.eye.y + (16.0 - im.eye.y) * d / (zv as f64 + d),
        ];
        // Region 2's rays are 4x denser than the baseplane's: sample j is
        // region-2 ray 4 m_j, and the lit ray is k = 4 (star - x_j) / spacing
        // region-2 rays away from it, which must be an integer.
        let k = |j: usize, a: usize| {
            let x = g.origin[a] + j as f64 * g.spacing;
            let k = 4.0 * (star[a] - x) / g.spacing;
            assert!(
                (k - k.round()).abs() < 1e-6,
                "lit ray off the region-2 grid: {k}"
            );
            k.round() as i64
        };
        let total: f64 = bp.data.iter().map(|p| p[3] as f64).sum();
        let a_star = correct_opacity(1e-4, im.ds(star[0], star[1]) as f32) as f64;
        // Every sample reaches the baseplane with weight 1/16 in all.
        assert!(
            (total * 16.0 / a_star - 1.0).abs() < 1e-3,
            "r ({rx},{ry}): baseplane sum {total} want {a_star} / 16"
        );
        let mut lit = 0;
        for jy in 0..g.counts[1] {
            for jx in 0..g.counts[0] {
                let want = cascade2(k(jx, 0)) * cascade2(k(jy, 1)) * a_star;
                let got = bp.data[jy * g.counts[0] + jx];
                for (c, &v) in got.iter().enumerate() {
                    assert!(
                        (v as f64 - want).abs() < 1e-3 * a_star / 16.0,
                        "r ({rx},{ry}) sample ({jx},{jy}) ch {c}: {v} want {want}"
                    );
                }
                lit += (want > 0.0) as usize;
            }
        }
        // Offset r mod 4 = 0 hits one baseplane sample per axis (weight 4/16),
        // any other offset two (3/16 + 1/16 or 2/16 + 2/16).
        let per_axis = |r: i64| if r == 0 { 1 } else { 2 };
        assert_eq!(lit, per_axis(rx) * per_axis(ry), "r ({rx},{ry})");
    }
}

#[test]
fn two_merges_end_to_end_impulse_matches_the_hand_computed_baseplane() {
    // With a linear, nearly transparent transfer function (alpha = 1e-4 s /
    // 255) every region-2 ray near the voxel sees it with the bilinear
    // weight hat(dx) hat(dy) and composites it alone: its state is
    // a' = 1 - (1 - alpha)^ds. Two merges then give baseplane sample j
    //   B_j = sum_k w(kx) w(ky) a'(x_j + kx s / 4, y_j + ky s / 4),
    // with s the baseplane spacing and w the 7-tap cascade (region-2 rays
    // are 4x denser than region 0's, and ray 4m continues ray m): computed
    // here from the baseplane's origin and spacing and the eye alone, not
    // from the library's region-2 ray grid or merge code.
    let (d, zv) = (6.0, 24usize);
    let l = lut(&tf(&[
        (0.0, [1.0, 1.0, 1.0, 0.0]),
        (255.0, [1.0, 1.0, 1.0, 1e-4]),
    ]));
    for (ex, ey, zv) in [
        (16.0, 16.0, zv),
        (16.37, 15.81, zv),
        (15.2, 17.45, 19),
        (16.0, 16.0, 31),
    ] {
        assert!(Regions::new(d, IMPULSE_N).slices(2).contains(&zv));
        let im = impulse_view(d, zv, ex, ey, None);
        let out = slice_render(Method::Er, &im.prep, &l, &opts(1.0, 1));
        assert_eq!(out.stats.merges, 2);
        let bp = &out.baseplane;
        let g = bp.grid;
        let [w, h] = g.counts;
        let a_prime = |u: f64, v: f64| {
            let (px, py) = im.at_voxel_slice(u, v);
            let alpha = 1e-4 * hat(px - 16.0) * hat(py - 16.0);
            1.0 - (1.0 - alpha).powf(im.ds(u, v))
        };
        let q = g.spacing / 4.0;
        let mut want = vec![0f64; w * h];
        for jy in 0..h {
            for jx in 0..w {
                let (u, v) = (
                    g.origin[0] + jx as f64 * g.spacing,
                    g.origin[1] + jy as f64 * g.spacing,
                );
                let mut acc = 0.0;
                for ky in -3..=3i64 {
                    for kx in -3..=3i64 {
                        acc += cascade2(kx)
                            * cascade2(ky)
                            * a_prime(u + kx as f64 * q, v + ky as f64 * q);
                    }
                }
                want[jy * w + jx] = acc;
            }
        }
        let peak = want.iter().cloned().fold(0.0, f64::max);
        assert!(peak > 0.0);
        for (i, (got, &want)) in bp.data.iter().zip(&want).enumerate() {
            for (c, &v) in got.iter().enumerate() {
                assert!(
                    (v as f64 - want).abs() < 1e-3 * peak,
                    "eye ({ex},{ey}) zv {zv}: sample {i} ch {c}: {v} want {want}"
                );
            }
        }
        // Energy: every region-2 sample reaches the baseplane with weight
        // 1/16 (1/4 per axis), so the baseplane sums to the samples' sum / 16.
        // Region-2 rays lie on the baseplane grid refined 4x; sum over all
        // of them near the voxel.
        let (lo, hi) = (-(4 * 4) as i64, ((w.max(h) + 4) * 4) as i64);
        let mut samples = 0.0;
        for ny in lo..=hi {
            for nx in lo..=hi {
                samples += a_prime(g.origin[0] + nx as f64 * q, g.origin[1] + ny as f64 * q);
            }
        }
        let total: f64 = bp.data.iter().map(|p| p[3] as f64).sum();
        assert!(
            (total * 16.0 / samples - 1.0).abs() < 1e-4,
            "eye ({ex},{ey}): baseplane sum {total} * 16 vs samples {samples}"
        );
        // Footprint: sample j is lit iff some region-2 ray within 3 of 4 m_j
        // sees the voxel (|dx| < 1 on slice zv). Compare bounding boxes.
        let lit = |f: &dyn Fn(usize) -> bool| {
            let (mut x0, mut x1, mut y0, mut y1) = (usize::MAX, 0, usize::MAX, 0);
            for i in (0..w * h).filter(|&i| f(i)) {
                x0 = x0.min(i % w);
                x1 = x1.max(i % w);
                y0 = y0.min(i / w);
                y1 = y1.max(i / w);
            }
            (x0, x1, y0, y1)
        };
        let got_box = lit(&|i| bp.data[i][3] > 0.0);
        let want_box = lit(&|i| want[i] > 1e-9 * peak);
        assert_eq!(got_box, want_box, "eye ({ex},{ey}) zv {zv}: footprint");
        eprintln!(
            "impulse eye ({ex},{ey}) zv {zv}: footprint {}x{} baseplane samples, sum {total:.4e}",
            got_box.1 - got_box.0 + 1,
            got_box.3 - got_box.2 + 1
        );
        if (ex, ey) == (16.0, 16.0) {
            // Centred: the voxel is on the central ray, which is baseplane
            // sample (j0, j0); the baseplane is symmetric about it on both axes
            // and under transposition.
            let j0 = ((16.0 - g.origin[0]) / g.spacing).round() as usize;
            assert!((g.origin[0] + j0 as f64 * g.spacing - 16.0).abs() < 1e-9);
            assert_eq!(g.origin[0], g.origin[1]);
            let b = |x: usize, y: usize| bp.data[y * w + x][3];
            let r = got_box.1 - j0;
            assert_eq!(j0 - got_box.0, r, "footprint centred on the voxel's ray");
            for dy in 0..=r {
                for dx in 0..=r {
                    let v = b(j0 + dx, j0 + dy);
                    for other in [
                        b(j0 - dx, j0 + dy),
                        b(j0 + dx, j0 - dy),
                        b(j0 + dy, j0 + dx),
                    ] {
                        assert!(
                            (v - other).abs() <= 1e-6 * peak as f32,
                            "({dx},{dy}): {v} vs {other}"
                        );
                    }
                }
            }
            // Closed form: region-2 rays on slice zv are at 16 + k t2, and
            // those with |k| t2 < 1 see the voxel: k = -1, 0, 1 (t2 in (1/2, 1)),
            // with bilinear weights h(0) = 1, h(+-1) = 1 - t2 per axis. Sample
            // j0 + dj is region-2 ray 4 dj from the voxel's, so per axis it
            // collects P(0) = (w(-1) h + w(0) + w(1) h) = (4 + 6 h) / 16,
            // P(+-1) = w(3) h = h / 16 and nothing beyond: a footprint 3
            // samples wide and a profile ratio h / (4 + 6 h) (up to the
            // slight change of ds between rays).
            let b3 = Regions::new(d, IMPULSE_N).bounds[3];
            let h = 1.0 - (zv as f64 + d) / (b3 + d);
            assert_eq!(r, 1, "zv {zv}: footprint 3 samples wide");
            let want = h / (4.0 + 6.0 * h);
            for side in [j0 - 1, j0 + 1] {
                let ratio = (b(side, j0) / b(j0, j0)) as f64;
                assert!(
                    (ratio / want - 1.0).abs() < 1e-3,
                    "zv {zv}: profile {ratio} want {want}"
                );
            }
            eprintln!(
                "  profile ratio {:.5} (closed form {want:.5})",
                b(j0 + 1, j0) / b(j0, j0)
            );
        }
    }
}

#[test]
fn every_sample_reaches_the_image_with_weight_pixels_over_samples() {
    // The centred impulse again, imaged on the front plane with pixels one
    // voxel apart (tan(fov/2) = H / (2 D)), pixel centres on baseplane
    // samples. The warp's tent of one voxel is then the third Bartlett merge
    // (1/4, 1/2, 1/4 on every 2nd sample): each baseplane sample reaches the
    // image with weight 1/4 in all, and each region-2 sample with
    // 1/64 = (1 pixel per voxel^2) / (64 region-2 rays per voxel^2 on the
    // baseplane): pixels / samples in its slice.
    let (d, zv, size) = (6.0, 24usize, 32u32);
    let fov = 2.0 * (size as f64 / (2.0 * d)).atan().to_degrees();
    let im = impulse_view(d, zv, 16.0, 16.0, Some((fov, size)));
    let l = lut(&tf(&[
        (0.0, [1.0, 1.0, 1.0, 0.0]),
        (255.0, [1.0, 1.0, 1.0, 1e-4]),
    ]));
    let frame = render(
        &im.prep,
        &l,
        Technique::Slice(Method::Er),
        &RenderOptions::default(),
    )
    .unwrap();
    let bp = &frame.slice.as_ref().unwrap().baseplane;
    let base_sum: f64 = bp.data.iter().map(|p| p[0] as f64).sum();
    let img_sum: f64 = frame.image.data.iter().map(|p| p[0] as f64).sum();
    let a_prime = |u: f64, v: f64| {
        let (px, py) = im.at_voxel_slice(u, v);
        let alpha = 1e-4 * hat(px - 16.0) * hat(py - 16.0);
        1.0 - (1.0 - alpha).powf(im.ds(u, v))
    };
    let mut samples = 0.0;
    for ny in -40..=40 {
        for nx in -40..=40 {
            samples += a_prime(16.0 + nx as f64 / 8.0, 16.0 + ny as f64 / 8.0);
        }
    }
    eprintln!("image sum {img_sum:.5e}, baseplane sum {base_sum:.5e}, samples {samples:.5e}");
    assert!(
        (img_sum * 4.0 / base_sum - 1.0).abs() < 1e-4,
        "{img_sum} vs {base_sum} / 4"
    );
    assert!(
        (img_sum * 64.0 / samples - 1.0).abs() < 1e-4,
        "{img_sum} vs {samples} / 64"
    );
}
