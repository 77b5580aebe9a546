//! `schollmeyer-transparent` and `schollmeyer-glass-depth` (seed 000, §4.2,
//! §5.3, Fig. 7): a fully transparent fragment changes nothing; a fully
//! opaque one hides the surface behind it; ray casting through the min-max
//! quadtree hits exactly the fragments a brute-force march over every
//! sample hits, visiting fewer cells; and on a pane in front of a wall the
//! ray cast beats both of the paper's baselines.

use glam::DVec3;
use postwarp::methods::schollmeyer::minmax::{MinMaxQuadtree, Segment, brute_force, cast};
use postwarp::methods::schollmeyer::transparent::{EXTRUSION, OPACITY_THRESHOLD};
use postwarp::methods::{self, Input, MethodFrame, NoFill};
use postwarp::scene::Scene;
use postwarp::trace::layers::{Fragment, FragmentLayer, Layers};
use postwarp_rtl::{Camera, FrameCommands, Intrinsics, Pose, SampleImage};

const SPLINE: &str = r#"
[spline]
duration_s = 4.0
[[spline.waypoints]]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, 5.0]
[[spline.waypoints]]
position = [1.0, 0.0, 0.0]
look_at = [1.0, 0.0, 5.0]
"#;

/// A striped wall at z = 5 and, if `opacity` is given, a tinted pane at
/// z = 2 over x, y in [-0.4, 0.4].
fn scene(opacity: Option<f64>) -> Scene {
    let pane = match opacity {
        None => String::new(),
        Some(a) => format!(
            "[materials.glass]\ncolour = [0.2, 0.6, 1.0]\nopacity = {a}\n[[objects]]\nkind = \"plane\"\nmaterial = \"glass\"\n\
             centre = [0.0, 0.0, 2.0]\nhalf_u = [0.4, 0.0, 0.0]\nhalf_v = [0.0, 0.4, 0.0]\n"
        ),
    };
    let text = format!(
        r#"
[light]
ambient = 1.0
[materials.wall]
colour = [0.9, 0.8, 0.3]
texture = {{ kind = "stripes", period = 0.6, axis = [1.0, 0.0, 0.0], colour = [0.2, 0.2, 0.5] }}
[[objects]]
kind = "plane"
material = "wall"
centre = [0.0, 0.0, 5.0]
half_u = [30.0, 0.0, 0.0]
half_v = [0.0, 30.0, 0.0]
{pane}{SPLINE}"#
    );
    Scene::from_toml_str(&text, None, "pane.toml").unwrap()
}

fn camera(x: f64) -> Camera {
    Camera {
        intrinsics: Intrinsics::from_hfov(48, 36, 40.0),
        pose: Pose::look_at(DVec3::new(x, 0.0, 0.0), DVec3::new(x, 0.0, 5.0), DVec3::Y),
    }
}

/// Run `name` (with no hole fill) on one reference image with `layers`.
fn run(name: &str, img: &SampleImage, layers: &Layers, ref_cam: &Camera, new_cam: &Camera) -> MethodFrame {
    let rec = methods::reconstruction(name).unwrap();
    let p = rec.prepare_layers(img, layers, ref_cam, 2);
    let cmd = FrameCommands::new(0, *new_cam, 2, &[(0, *ref_cam)]);
    let refs = [img];
    let input = Input { cmd: &cmd, refs: &refs, prepared: &[&p] };
    methods::render(rec.as_ref(), &NoFill, &input, input.empty_frame())
}

#[test]
fn a_fully_transparent_fragment_changes_nothing() {
    let (ref_cam, new_cam) = (camera(0.0), camera(0.2));
    let r = scene(Some(0.0)).render_layers(&ref_cam, 2, 4);
    let f = r.fragments.clone().unwrap();
    assert!(f.count.iter().filter(|&&c| c == 1).count() > 400, "the pane is in the fragment layer");
    let layers = Layers { fragments: r.fragments, raytree: None };
    let with = run("schollmeyer-transparent", &r.samples, &layers, &ref_cam, &new_cam);
    let without = run("schollmeyer-irregular", &r.samples, &Layers::default(), &ref_cam, &new_cam);
    assert!(with.reconstruction.extra["fragment_hits"].as_u64().unwrap() > 400, "{:?}", with.reconstruction);
    assert_eq!(with.samples.colour, without.samples.colour);
    assert_eq!(with.samples.inv_z, without.samples.inv_z);
    assert_eq!(with.pixels, without.pixels);
}

#[test]
fn a_fully_opaque_fragment_hides_the_surface_behind() {
    let (ref_cam, new_cam) = (camera(0.0), camera(0.2));
    let wall = scene(None).render_layers(&ref_cam, 2, 4).samples;
    // A red fragment of opacity 1 at depth 2 wherever the pane is, by hand
    // (the renderer makes an opacity-1 surface opaque, not a fragment).
    let g = ref_cam.sample_grid(2);
    let mut f = FragmentLayer::empty(wall.width, wall.height, 2);
    let mut img = wall.clone();
    let on_pane = |cam: &Camera, x: f64, y: f64, margin: f64| {
        let d = cam.ray_direction(x, y);
        let p = cam.pose.position + d * (2.0 / d.z);
        p.x.abs() < 0.4 - margin && p.y.abs() < 0.4 - margin
    };
    for y in 0..wall.height {
        for x in 0..wall.width {
            if on_pane(&g, x as f64, y as f64, 0.0) {
                let i = img.index(x, y);
                f.count[i] = 1;
                f.opaque[i] = wall.colour[i];
                f.fragments[i * 2] = Fragment { colour: [1.0, 0.0, 0.0], alpha: 1.0, z: 2.0 };
                img.colour[i] = [1.0, 0.0, 0.0];
            } else {
                let i = img.index(x, y);
                f.opaque[i] = wall.colour[i];
            }
        }
    }
    let layers = Layers { fragments: Some(f), raytree: None };
    let out = run("schollmeyer-transparent", &img, &layers, &ref_cam, &new_cam);
    let plain = run("schollmeyer-irregular", &wall, &Layers::default(), &ref_cam, &new_cam);
    let d = new_cam.sample_grid(2);
    let (mut hidden, mut seen) = (0, 0);
    for y in 0..out.samples.height {
        for x in 0..out.samples.width {
            let i = (y * out.samples.width + x) as usize;
            if on_pane(&d, x as f64, y as f64, 0.02) {
                assert_eq!(out.samples.colour[i], [1.0, 0.0, 0.0], "({x}, {y}) behind the opaque fragment");
                assert_eq!(out.samples.inv_z[i], plain.samples.inv_z[i], "fragments write no depth");
                hidden += 1;
            } else if !on_pane(&d, x as f64, y as f64, -0.02) && plain.samples.real[i] {
                assert_eq!(out.samples.colour[i], plain.samples.colour[i], "({x}, {y}) beside it: the wall");
                seen += 1;
            }
        }
    }
    assert!(hidden > 300 && seen > 1000, "{hidden} {seen}");
    // The grid warp of the composited colour with the opaque depth (the
    // paper's first baseline, Fig. 7c) paints the pane onto the wall: at
    // this parallax it shows red where the wall is.
    let painted = run("schollmeyer-irregular", &img, &Layers::default(), &ref_cam, &new_cam);
    let wrong = (0..out.samples.len())
        .filter(|&i| painted.samples.colour[i] == [1.0, 0.0, 0.0] && out.samples.colour[i] != [1.0, 0.0, 0.0])
        .count();
    assert!(wrong > 50, "{wrong}");
}

/// A deterministic generator for the march test.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn quadtree_ray_casting_hits_what_a_brute_force_march_hits() {
    // A 96x72-sample reference with fragments on three tilted panes, one
    // behind another, some samples with up to three fragments.
    let ref_cam = Camera {
        intrinsics: Intrinsics::from_hfov(96, 72, 60.0),
        pose: Pose::look_at(DVec3::ZERO, DVec3::new(0.0, 0.0, 5.0), DVec3::Y),
    };
    let mut layer = FragmentLayer::empty(96, 72, 3);
    let panes = [(1.5, 0.3, -0.8, 0.6), (2.5, -0.2, -0.3, 1.5), (4.0, 0.1, -1.5, 0.4)];
    for y in 0..72 {
        for x in 0..96 {
            let i = y * 96 + x;
            let d = ref_cam.ray_direction(x as f64, y as f64);
            let mut n = 0;
            for (z0, slope, x_lo, x_hi) in panes {
                // Plane z = z0 + slope·x over x in [x_lo, x_hi].
                let t = z0 / (d.z - slope * d.x);
                let p = d * t;
                if t > 0.0 && p.x >= x_lo && p.x <= x_hi && p.y.abs() < 1.0 {
                    layer.fragments[i * 3 + n] = Fragment { colour: [0.5; 3], alpha: 0.3, z: p.z as f32 };
                    n += 1;
                }
            }
            layer.count[i] = n as u8;
        }
    }
    let tree = MinMaxQuadtree::build(&layer);
    let mut rng = Lcg(7);
    let (mut rays, mut with_hits, mut cells_tree, mut cells_brute) = (0, 0, 0u64, 0u64);
    for _ in 0..3000 {
        let origin = DVec3::new(rng.next() * 2.0 - 1.0, rng.next() - 0.5, rng.next() * 1.0 - 0.5);
        let target = DVec3::new(rng.next() * 4.0 - 2.0, rng.next() * 2.0 - 1.0, 5.0);
        let dir = target - origin;
        let dir = dir / dir.z; // camera-space z of 1 for a camera looking down +z
        let t_far = if rng.next() < 0.3 { f64::INFINITY } else { 1.0 + rng.next() * 5.0 };
        let Some(seg) = Segment::new(origin, dir, t_far, &ref_cam) else { continue };
        for threshold in [OPACITY_THRESHOLD, 0.5] {
            let a = cast(&seg, &tree, &layer, EXTRUSION, threshold);
            let b = brute_force(&seg, &layer, EXTRUSION, threshold);
            assert_eq!(a.hits, b.hits, "ray from {origin} along {dir} to {t_far}");
            cells_tree += a.cells_visited;
            cells_brute += b.cells_visited;
            with_hits += (!a.hits.is_empty()) as u32;
        }
        rays += 1;
    }
    assert!(rays > 2500 && with_hits > 1000, "{rays} rays, {with_hits} with hits");
    // The panes cover much of the view, so many rays pass near fragments
    // all along (measured: 183,690 against 311,204 cells).
    assert!(cells_tree * 3 < cells_brute * 2, "quadtree {cells_tree} vs march {cells_brute} cells");
}

#[test]
fn ray_casting_beats_both_baselines_on_a_pane_before_a_wall() {
    let (ref_cam, new_cam) = (camera(0.0), camera(0.3));
    let s = scene(Some(0.5));
    let r = s.render_layers(&ref_cam, 2, 4);
    let layers = Layers { fragments: r.fragments, raytree: None };
    let truth = s.render(&new_cam, 2).colour;
    let err = |f: &MethodFrame| {
        let e: f64 = f
            .samples
            .colour
            .iter()
            .zip(&truth)
            .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs() as f64).sum::<f64>())
            .sum();
        e / truth.len() as f64
    };
    let cast = err(&run("schollmeyer-transparent", &r.samples, &layers, &ref_cam, &new_cam));
    let glass = err(&run("schollmeyer-glass-depth", &r.samples, &layers, &ref_cam, &new_cam));
    let opaque = err(&run("schollmeyer-irregular", &r.samples, &layers, &ref_cam, &new_cam));
    // The floor: the same warp of the wall alone (resampling the stripes).
    let bare = scene(None);
    let rb = bare.render_layers(&ref_cam, 2, 4);
    let truth_bare = bare.render(&new_cam, 2).colour;
    let f = run("schollmeyer-irregular", &rb.samples, &Layers::default(), &ref_cam, &new_cam);
    let e: f64 = f
        .samples
        .colour
        .iter()
        .zip(&truth_bare)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs() as f64).sum::<f64>())
        .sum();
    let floor = e / truth_bare.len() as f64;
    assert!(
        cast - floor < 0.25 * (glass.min(opaque) - floor),
        "cast {cast}, glass depth {glass}, opaque depth {opaque}, wall alone {floor}"
    );
}
