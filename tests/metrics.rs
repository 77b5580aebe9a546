//! `postwarp::metrics::evaluate` end to end: masks, holes, errors,
//! serialization, and the docs listing every report key.

use bitvec::vec::BitVec;
use postwarp::metrics::{MetricError, MetricInput, Quality, describe, evaluate};
use postwarp::picture::srgb_to_linear;

/// Deterministic 64-bit LCG (Knuth's constants); returns the high bits.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 32) as u32
    }
}

/// A `w x h` linear-RGB picture whose sRGB codes are exact: smooth gradients
/// with a checkerboard, so SSIM and FLIP have structure to see.
fn picture(w: u32, h: u32) -> Vec<[f32; 3]> {
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let check = if (x / 8 + y / 8) % 2 == 0 { 50 } else { 0 };
            let r = (x * 150 / w + check) as u8;
            let g = (y * 150 / h + 40) as u8;
            let b = (200 - check) as u8;
            [srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b)]
        })
        .collect()
}

fn input<'a>(
    w: u32,
    h: u32,
    image: &'a [[f32; 3]],
    truth: &'a [[f32; 3]],
    known: &'a BitVec,
    covered: Option<&'a BitVec>,
) -> MetricInput<'a> {
    MetricInput { width: w, height: h, image, truth, known, covered, common: None, seen: None, flip: true }
}

#[test]
fn identical_images_score_perfectly() {
    let (w, h) = (48, 40);
    let t = picture(w, h);
    let known = BitVec::repeat(true, (w * h) as usize);
    let q = evaluate(&input(w, h, &t, &t, &known, None)).unwrap();
    assert_eq!(q.psnr_rgb_db, f64::INFINITY);
    assert_eq!(q.psnr_rgb_covered_db, f64::INFINITY);
    assert_eq!(q.psnr_luma_db, f64::INFINITY);
    assert!((q.ssim_luma - 1.0).abs() < 1e-12, "{}", q.ssim_luma);
    assert_eq!(q.flip_mean, 0.0);
    assert_eq!(q.hole_fraction, 0.0);
    assert_eq!(q.delta_e20_fraction, 0.0);
    assert_eq!((q.excluded_pixels, q.covered_pixels, q.scored_pixels), (0, 1920, 1920));
    let json = serde_json::to_value(&q).unwrap();
    assert!(json["psnr_rgb_db"].is_null() && json["psnr_luma_db"].is_null());
    assert_eq!(json["ssim_luma"].as_f64(), Some(q.ssim_luma));
    assert_eq!(json["scored_pixels"].as_u64(), Some(1920));
}

#[test]
fn unknown_pixels_are_excluded_from_every_metric() {
    let (w, h) = (40, 40);
    let truth = picture(w, h);
    let mut image = truth.clone();
    let mut known = BitVec::repeat(true, (w * h) as usize);
    // A huge error, and NaN/inf, only where the truth is unknown.
    for y in 10..20 {
        for x in 5..30 {
            let i = (y * w + x) as usize;
            image[i] = [1.0 - truth[i][0], f32::NAN, f32::INFINITY];
            known.set(i, false);
        }
    }
    let holes = BitVec::repeat(false, (w * h) as usize);
    let q = evaluate(&input(w, h, &image, &truth, &known, Some(&holes))).unwrap();
    assert_eq!(q.excluded_pixels, 250);
    assert_eq!(q.scored_pixels, 1600 - 250);
    assert_eq!(q.psnr_rgb_db, f64::INFINITY);
    assert_eq!(q.psnr_luma_db, f64::INFINITY);
    assert!((q.ssim_luma - 1.0).abs() < 1e-12);
    assert_eq!(q.flip_mean, 0.0);
    assert_eq!(q.delta_e20_fraction, 0.0);
    // Nothing covered: the covered PSNR has nothing to score, every known pixel is a hole.
    assert!(q.psnr_rgb_covered_db.is_nan());
    assert_eq!(q.covered_pixels, 0);
    assert_eq!(q.hole_fraction, 1.0);

    // The same error on known pixels is seen by every metric.
    let all = BitVec::repeat(true, (w * h) as usize);
    let q = evaluate(&input(w, h, &image, &truth, &all, None)).unwrap();
    assert!(q.psnr_rgb_db < 20.0 && q.psnr_luma_db < 40.0, "{q:?}");
    assert!(q.ssim_luma < 0.9 && q.flip_mean > 0.05 && q.delta_e20_fraction >= 0.1, "{q:?}");
}

#[test]
fn holes_drive_hole_fraction_and_covered_psnr() {
    let (w, h) = (32, 32);
    let truth = picture(w, h);
    let n = (w * h) as usize;
    let mut image = truth.clone();
    let mut covered = BitVec::repeat(true, n);
    // Hole-filled pixels with a large error: the top 8 rows.
    let top = (8 * w) as usize;
    image[..top].fill([0.0, 0.0, 0.0]);
    covered[..top].fill(false);
    // Covered pixels with an exact error of 2 codes in green on every 4th pixel.
    let bump = |c: f32| {
        let code = postwarp::picture::linear_to_srgb8(c);
        srgb_to_linear(code + 2)
    };
    for i in ((8 * w) as usize..n).step_by(4) {
        image[i][1] = bump(truth[i][1]);
    }
    let mut known = BitVec::repeat(true, n);
    known.set(n - 1, false); // an unknown, covered pixel
    known.set(0, false); // an unknown hole
    let q = evaluate(&input(w, h, &image, &truth, &known, Some(&covered))).unwrap();
    assert_eq!(q.excluded_pixels, 2);
    assert_eq!(q.scored_pixels, 1022);
    assert_eq!(q.covered_pixels, 768 - 1);
    assert_eq!(q.hole_fraction, 255.0 / 1022.0);
    // Covered, known pixels: 767, of which the 192 at 256, 260, ..., 1020 are off by 2 codes in G.
    let want = 10.0 * (255.0f64 * 255.0 / (192.0 * 4.0 / (3.0 * 767.0))).log10();
    assert!((q.psnr_rgb_covered_db - want).abs() < 1e-9, "{} vs {want}", q.psnr_rgb_covered_db);
    assert!(q.psnr_rgb_db < q.psnr_rgb_covered_db - 20.0, "{q:?}");

    // covered = None means every pixel is covered.
    let q2 = evaluate(&input(w, h, &image, &truth, &known, None)).unwrap();
    assert_eq!(q2.hole_fraction, 0.0);
    assert_eq!(q2.covered_pixels, 1022);
    assert_eq!(q2.psnr_rgb_covered_db, q2.psnr_rgb_db);
    assert_eq!(q2.psnr_rgb_db, q.psnr_rgb_db);
}

#[test]
fn more_error_scores_worse_on_every_metric() {
    let (w, h) = (64, 64);
    let truth = picture(w, h);
    let known = BitVec::repeat(true, (w * h) as usize);
    let mut rng = Lcg(7);
    let noise: Vec<[f32; 3]> =
        (0..w * h).map(|_| [0, 1, 2].map(|_| rng.next() as f32 / u32::MAX as f32 - 0.5)).collect();
    let mut last: Option<Quality> = None;
    for amp in [0.02f32, 0.1, 0.4] {
        let image: Vec<[f32; 3]> =
            truth.iter().zip(&noise).map(|(t, n)| [0, 1, 2].map(|c| t[c] + amp * n[c])).collect();
        let q = evaluate(&input(w, h, &image, &truth, &known, None)).unwrap();
        assert!(q.psnr_rgb_db.is_finite() && q.ssim_luma < 1.0 && q.flip_mean > 0.0, "{q:?}");
        if let Some(p) = &last {
            assert!(q.psnr_rgb_db < p.psnr_rgb_db && q.psnr_luma_db < p.psnr_luma_db, "{amp}");
            assert!(q.ssim_luma < p.ssim_luma && q.flip_mean > p.flip_mean, "{amp}");
            assert!(q.delta_e20_fraction >= p.delta_e20_fraction, "{amp}");
        }
        last = Some(q);
    }
    let q = last.unwrap();
    assert!(q.delta_e20_fraction > 0.2, "{q:?}");
}

#[test]
fn evaluate_is_deterministic() {
    let (w, h) = (50, 30);
    let truth = picture(w, h);
    let image: Vec<[f32; 3]> = truth.iter().map(|c| [c[1], c[2], c[0]]).collect();
    let known = BitVec::repeat(true, (w * h) as usize);
    // A seen mask with a never-seen strip, so every score is a number.
    let seen: BitVec = (0..w * h).map(|i| i % w < w - 5).collect();
    let a = evaluate(&MetricInput { seen: Some(&seen), ..input(w, h, &image, &truth, &known, None) }).unwrap();
    let b = evaluate(&MetricInput { seen: Some(&seen), ..input(w, h, &image, &truth, &known, None) }).unwrap();
    assert!(a.psnr_rgb_never_seen_db.is_finite() && a.never_seen_pixels == 150, "{a:?}");
    assert_eq!(a, b);
    assert_eq!(serde_json::to_string(&a).unwrap(), serde_json::to_string(&b).unwrap());
}

#[test]
fn size_mismatches_are_errors_not_panics() {
    let (w, h) = (8u32, 6u32);
    let n = 48;
    let px = vec![[0.5f32; 3]; n];
    let short = vec![[0.5f32; 3]; n - 1];
    let known = BitVec::repeat(true, n);
    let known_long = BitVec::repeat(true, n + 1);
    let cases = [
        (input(w, h, &short, &px, &known, None), "image"),
        (input(w, h, &px, &short, &known, None), "truth"),
        (input(w, h, &px, &px, &known_long, None), "known mask"),
        (input(w, h, &px, &px, &known, Some(&known_long)), "covered mask"),
        (input(w + 1, h, &px, &px, &known, None), "image"),
    ];
    for (inp, what) in cases {
        match evaluate(&inp) {
            Err(e @ MetricError::SizeMismatch { what: got, .. }) => {
                assert_eq!(got, what);
                assert!(e.to_string().starts_with(what), "{e}");
            }
            other => panic!("{what}: {other:?}"),
        }
    }
    let empty = BitVec::new();
    assert!(matches!(evaluate(&input(0, 5, &[], &[], &empty, None)), Err(MetricError::Empty { .. })));
}

#[test]
fn nothing_known_gives_nan_and_null() {
    let (w, h) = (12, 12);
    let t = picture(w, h);
    let known = BitVec::repeat(false, 144);
    let q = evaluate(&input(w, h, &t, &t, &known, None)).unwrap();
    for v in [q.psnr_rgb_db, q.psnr_rgb_covered_db, q.psnr_luma_db, q.ssim_luma, q.flip_mean] {
        assert!(v.is_nan(), "{q:?}");
    }
    assert!(q.hole_fraction.is_nan() && q.delta_e20_fraction.is_nan());
    assert_eq!((q.excluded_pixels, q.scored_pixels, q.covered_pixels), (144, 0, 0));
    let json = serde_json::to_value(&q).unwrap();
    for d in describe().iter().filter(|d| d.unit != "pixels") {
        assert!(json[d.key].is_null(), "{}", d.key);
    }
}

#[test]
fn small_images_use_the_clipped_window() {
    // Smaller than the 11x11 SSIM window on both axes, and on one.
    for (w, h) in [(5u32, 4u32), (30, 3), (1, 1)] {
        let truth = picture(w, h);
        let image: Vec<[f32; 3]> = truth.iter().map(|c| c.map(|v| v * 0.5)).collect();
        let known = BitVec::repeat(true, (w * h) as usize);
        let q = evaluate(&input(w, h, &image, &truth, &known, None)).unwrap();
        assert!(q.ssim_luma.is_finite() && q.ssim_luma < 1.0, "{w}x{h}: {q:?}");
        assert!(q.flip_mean.is_finite() && q.flip_mean > 0.0, "{w}x{h}: {q:?}");
    }
}

#[test]
fn docs_describe_every_key() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/metrics.md")).unwrap();
    for d in describe() {
        assert!(doc.contains(&format!("`{}`", d.key)), "docs/metrics.md does not mention `{}`", d.key);
    }
    assert!(doc.contains("67"), "docs/metrics.md must give FLIP's pixels per degree");
}

/// The common mask is exactly known ∧ seen ∧ every covered mask, and the
/// `*_common` keys score exactly its pixels: a constructed 6x5 case where
/// each term removes different pixels, an error planted on each removed
/// pixel (it must not count) and a known error on the mask.
#[test]
fn the_common_mask_is_the_intersection_it_claims() {
    use postwarp::metrics::common_mask;
    let (w, h) = (24u32, 20u32);
    let n = (w * h) as usize;
    let mut rng = Lcg(15);
    let mut bits = |p: u32| -> BitVec { (0..n).map(|_| rng.next() % 100 >= p).collect() };
    let (known, seen, cov_a, cov_b) = (bits(10), bits(20), bits(15), bits(25));
    let common = common_mask(&known, Some(&seen), &[&cov_a, &cov_b]).unwrap();
    let mut expected = 0;
    for i in 0..n {
        let want = known[i] && seen[i] && cov_a[i] && cov_b[i];
        assert_eq!(common[i], want, "pixel {i}");
        expected += want as u64;
    }
    // Each term does remove pixels here, so a missing term would show.
    for term in [&known, &seen, &cov_a, &cov_b] {
        assert!((0..n).any(|i| !term[i] && common_without(i, term, &[&known, &seen, &cov_a, &cov_b])));
    }
    // Without `seen` the mask is known ∧ covered.
    let no_seen = common_mask(&known, None, &[&cov_a]).unwrap();
    assert_eq!(no_seen, known.clone() & &cov_a);

    // Truth grey 100; the image is 6 codes off on the common mask and 90
    // codes off everywhere else.
    let truth = vec![[srgb_to_linear(100); 3]; n];
    let image: Vec<[f32; 3]> = (0..n).map(|i| [srgb_to_linear(if common[i] { 106 } else { 10 }); 3]).collect();
    let q = evaluate(&MetricInput {
        width: w,
        height: h,
        image: &image,
        truth: &truth,
        known: &known,
        covered: Some(&cov_a),
        common: Some(&(seen.clone() & &cov_a & &cov_b)),
        seen: Some(&seen),
        flip: true,
    })
    .unwrap();
    assert_eq!(q.common_pixels, expected);
    let want = 10.0 * (255.0f64 * 255.0 / 36.0).log10();
    assert!((q.psnr_rgb_common_db - want).abs() < 1e-9, "{} vs {want}", q.psnr_rgb_common_db);
    assert!(q.psnr_rgb_db < 20.0, "the whole image sees the 90-code error: {}", q.psnr_rgb_db);
    // A mask of another size is an error naming it.
    let short = BitVec::repeat(true, n - 1);
    let e = common_mask(&known, Some(&short), &[]).unwrap_err();
    assert!(e.to_string().contains("seen mask has 479 entries; expected 480"), "{e}");
    let e = common_mask(&known, None, &[&cov_a, &short]).unwrap_err();
    assert!(e.to_string().contains("covered mask"), "{e}");
}

/// FLIP is computed only when asked: without it both FLIP keys are NaN and
/// every other score is the same number, with a common mask of its own
/// (the second FLIP) and without.
#[test]
fn flip_only_when_asked() {
    let (w, h) = (24u32, 20u32);
    let n = (w * h) as usize;
    let truth: Vec<[f32; 3]> = (0..n).map(|i| [srgb_to_linear((i * 7 % 251) as u8); 3]).collect();
    let image: Vec<[f32; 3]> = (0..n).map(|i| [srgb_to_linear((i * 7 % 251) as u8 / 2 + 40); 3]).collect();
    let known = BitVec::repeat(true, n);
    let common: BitVec = (0..n).map(|i| i % 3 != 0).collect();
    for common in [None, Some(&common)] {
        let with = MetricInput { common, ..input(w, h, &image, &truth, &known, None) };
        let a = evaluate(&with).unwrap();
        let b = evaluate(&MetricInput { flip: false, ..with }).unwrap();
        assert!(a.flip_mean > 0.0 && a.flip_mean_common > 0.0, "{a:?}");
        assert!(b.flip_mean.is_nan() && b.flip_mean_common.is_nan(), "{b:?}");
        let masked = |mut q: Quality| {
            q.flip_mean = 0.0;
            q.flip_mean_common = 0.0;
            q
        };
        // Debug text: NaN scores (nothing never-seen) compare equal there.
        assert_eq!(format!("{:?}", masked(a)), format!("{:?}", masked(b)));
    }
}

/// Pixel `i` is clear in `term` and set in every other mask of `all`.
fn common_without(i: usize, term: &BitVec, all: &[&BitVec]) -> bool {
    all.iter().all(|m| std::ptr::eq(*m, term) || m[i])
}
