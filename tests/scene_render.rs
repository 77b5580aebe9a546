//! Integration tests of the scene renderer: exact depth and 1/Z slopes on
//! planes, object ids, determinism (also across thread counts), misses,
//! bundled meshes, the built-in scenes and error messages.
//!
//! One `#[ignore]`d helper, `write_scene_previews`, renders the built-in
//! scenes to `docs/img/scene-<name>.png` (`cargo test --test suite scene_render:: --
//! --ignored write_scene_previews`).

use glam::{DQuat, DVec3};
use postwarp::scene::Scene;
use postwarp_rtl::{Camera, Intrinsics, Pose, SampleImage};
use std::collections::BTreeSet;
use std::path::Path;

const SPLINE: &str = r#"
[spline]
duration_s = 4.0
[[spline.waypoints]]
position = [0.0, 1.6, 4.0]
look_at = [0.0, 1.0, 0.0]
[[spline.waypoints]]
position = [1.0, 1.6, 4.0]
look_at = [0.0, 1.0, 0.0]
"#;

fn scene(body: &str) -> Scene {
    let text = format!("{body}\n{SPLINE}");
    Scene::from_toml_str(&text, None, "inline.toml").unwrap_or_else(|e| panic!("{e}"))
}

fn scene_err(text: &str) -> String {
    match Scene::from_toml_str(text, None, "inline.toml") {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn camera(w: u32, h: u32, hfov: f64, pos: DVec3, target: DVec3) -> Camera {
    Camera { intrinsics: Intrinsics::from_hfov(w, h, hfov), pose: Pose::look_at(pos, target, DVec3::Y) }
}

fn rel_close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn fronto_parallel_plane_has_exact_depth_and_zero_slopes() {
    let s = scene(
        r#"
[[objects]]
kind = "plane"
centre = [0.0, 0.0, 5.0]
half_u = [20.0, 0.0, 0.0]
half_v = [0.0, 20.0, 0.0]
"#,
    );
    let cam = camera(32, 24, 60.0, DVec3::ZERO, DVec3::new(0.0, 0.0, 5.0));
    for ss in [1, 2] {
        let img = s.render(&cam, ss);
        assert_eq!((img.width, img.height), (32 * ss, 24 * ss));
        assert_eq!(img.valid.count_ones(), img.len());
        for i in 0..img.len() {
            assert_eq!(img.z[i], 5.0, "sample {i}");
            assert_eq!(img.inv_z_slopes[i], [0.0, 0.0], "sample {i}");
            assert_eq!(img.object_id[i], 1);
        }
    }
}

#[test]
fn tilted_plane_slopes_match_the_plane_equation() {
    // The plane n·P = c in world space, seen from a general pose.
    let n_world = DVec3::new(0.3, 0.8, -1.0).normalize();
    let p0 = DVec3::new(0.2, 0.5, 6.0);
    let s = scene(&format!(
        "[[objects]]\nkind = \"plane\"\ncentre = [{}, {}, {}]\nnormal = [{}, {}, {}]\n",
        p0.x, p0.y, p0.z, n_world.x, n_world.y, n_world.z
    ));
    let cam = camera(32, 24, 50.0, DVec3::new(0.3, 1.2, -0.5), DVec3::new(0.5, 0.8, 5.0));
    let ss = 2;
    let img = s.render(&cam, ss);
    let grid = cam.sample_grid(ss);
    let k = grid.intrinsics;
    // Camera-space plane: n_c·X = d.
    let r = grid.pose.rotation();
    let n_c = r.transpose() * n_world;
    let d = n_c.dot(r.transpose() * (p0 - grid.pose.position));
    let expect_slopes = [n_c.x / (k.fx * d), n_c.y / (k.fy * d)];
    let inv_z = |x: u32, y: u32| {
        let (xn, yn) = ((x as f64 - k.cx) / k.fx, (y as f64 - k.cy) / k.fy);
        (n_c.x * xn + n_c.y * yn + n_c.z) / d
    };
    let mut checked = 0;
    for y in 0..img.height {
        for x in 0..img.width {
            let i = img.index(x, y);
            if inv_z(x, y) <= 0.0 {
                assert!(!img.valid[i], "({x},{y}) is behind the camera but valid");
                continue;
            }
            assert!(img.valid[i], "({x},{y})");
            checked += 1;
            assert!(
                rel_close(img.z[i] as f64, 1.0 / inv_z(x, y), 1e-6),
                "({x},{y}): Z {} vs {}",
                img.z[i],
                1.0 / inv_z(x, y)
            );
            for (a, (&got, &want)) in img.inv_z_slopes[i].iter().zip(&expect_slopes).enumerate() {
                assert!(rel_close(got as f64, want, 1e-6), "({x},{y}) axis {a}: {got} vs {want}");
            }
            // 1/Z differences between neighbours match the slopes (1/Z is
            // affine on a plane; f32 depth limits the agreement).
            if x + 1 < img.width && y + 1 < img.height {
                let iz = |j: usize| 1.0 / img.z[j] as f64;
                let dx = iz(img.index(x + 1, y)) - iz(i);
                let dy = iz(img.index(x, y + 1)) - iz(i);
                let tol = 1e-6 * iz(i) + 1e-3 * expect_slopes[0].abs().max(expect_slopes[1].abs());
                assert!((dx - expect_slopes[0]).abs() < tol, "({x},{y}): dx {dx} vs {}", expect_slopes[0]);
                assert!((dy - expect_slopes[1]).abs() < tol, "({x},{y}): dy {dy} vs {}", expect_slopes[1]);
            }
        }
    }
    assert!(checked > 1000, "{checked}");
    assert!(expect_slopes[0].abs() > 1e-4 && expect_slopes[1].abs() > 1e-4, "{expect_slopes:?}");
}

const SPHERE_BEFORE_PLANE: &str = r#"
background = [0.1, 0.2, 0.3]

[materials.red]
colour = [0.8, 0.1, 0.1]

[[objects]]
kind = "plane"
name = "backdrop"
centre = [0.0, 0.0, -10.0]
half_u = [3.0, 0.0, 0.0]
half_v = [0.0, 3.0, 0.0]

[[objects]]
kind = "sphere"
material = "red"
centre = [0.0, 0.0, -5.0]
radius = 1.0
"#;

#[test]
fn object_ids_follow_scene_order_and_the_sphere_is_nearer() {
    let s = scene(SPHERE_BEFORE_PLANE);
    let img = s.render(&camera(32, 24, 30.0, DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0)), 1);
    let ids: BTreeSet<u32> = img.object_id.iter().copied().collect();
    assert_eq!(ids, BTreeSet::from([1, 2]));
    let centre = img.index(16, 12);
    let edge = img.index(2, 12);
    assert_eq!((img.object_id[centre], img.object_id[edge]), (2, 1));
    let max_sphere = (0..img.len()).filter(|&i| img.object_id[i] == 2).map(|i| img.z[i]).fold(0.0, f32::max);
    let min_plane = (0..img.len()).filter(|&i| img.object_id[i] == 1).map(|i| img.z[i]).fold(f32::MAX, f32::min);
    assert!(max_sphere < min_plane, "{max_sphere} vs {min_plane}");
    assert!(img.z[centre] > 3.99 && img.z[centre] < 4.01, "{}", img.z[centre]);
    // The sphere's analytic slopes agree with finite differences inside it.
    let (x, y) = (18, 13);
    let i = img.index(x, y);
    let iz = |j: usize| 1.0 / img.z[j] as f64;
    let fdx = (iz(img.index(x + 1, y)) - iz(img.index(x - 1, y))) / 2.0;
    let fdy = (iz(img.index(x, y + 1)) - iz(img.index(x, y - 1))) / 2.0;
    assert!(rel_close(fdx, img.inv_z_slopes[i][0] as f64, 0.1), "{fdx} vs {:?}", img.inv_z_slopes[i]);
    assert!(rel_close(fdy, img.inv_z_slopes[i][1] as f64, 0.1), "{fdy} vs {:?}", img.inv_z_slopes[i]);
    // Red sphere is red; lit colours stay in [0, 1].
    let c = img.colour[centre];
    assert!(c[0] > c[1] && c[0] > c[2], "{c:?}");
    assert!(img.colour.iter().flatten().all(|&v| (0.0..=1.0).contains(&v)));
}

#[test]
fn rays_that_miss_are_invalid_with_the_background_colour() {
    let s = scene(SPHERE_BEFORE_PLANE);
    // Looking the other way: nothing there.
    let img = s.render(&camera(16, 12, 40.0, DVec3::ZERO, DVec3::new(0.0, 0.0, 1.0)), 1);
    assert_eq!(img.valid.count_ones(), 0);
    assert!(img.colour.iter().all(|c| *c == [0.1, 0.2, 0.3]));
    assert!(img.z.iter().all(|&z| z == 0.0));
    assert!(img.object_id.iter().all(|&id| id == 0));
    // Looking at the scene, the corners see past the 6 m backdrop.
    let img = s.render(&camera(32, 24, 90.0, DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0)), 1);
    let corner = img.index(0, 0);
    assert!(!img.valid[corner]);
    assert_eq!((img.colour[corner], img.z[corner], img.object_id[corner]), ([0.1, 0.2, 0.3], 0.0, 0));
    assert!(img.valid[img.index(16, 12)]);
}

fn assert_same(a: &SampleImage, b: &SampleImage) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(a.colour.as_flattened()), bits(b.colour.as_flattened()));
    assert_eq!(bits(&a.z), bits(&b.z));
    assert_eq!(bits(a.inv_z_slopes.as_flattened()), bits(b.inv_z_slopes.as_flattened()));
    assert_eq!(a.object_id, b.object_id);
    assert_eq!(a.valid, b.valid);
}

#[test]
fn rendering_is_deterministic_across_runs_and_thread_counts() {
    let s = Scene::builtin("occluders").unwrap();
    let w = &s.spline.waypoints[0];
    let cam = camera(40, 30, 60.0, w.position, w.look_at);
    let a = s.render(&cam, 2);
    let b = s.render(&cam, 2);
    assert_same(&a, &b);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let c = one.install(|| s.render(&cam, 2));
    assert_same(&a, &c);
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let d = three.install(|| s.render(&cam, 2));
    assert_same(&a, &d);
}

#[test]
fn bundled_teapot_is_hit_and_its_slopes_match_finite_differences() {
    let s = scene(
        r#"
[[objects]]
kind = "mesh"
file = "bundled:teapot.obj"
size = 1.0
rotate_deg = [0.0, 30.0, 0.0]
position = [0.0, 0.0, 0.0]
"#,
    );
    let img = s.render(&camera(64, 48, 30.0, DVec3::new(0.3, 0.9, 2.5), DVec3::new(0.0, 0.3, 0.0)), 2);
    let hits = img.valid.count_ones();
    assert!(hits > 2000, "{hits} samples hit the teapot");
    assert!(img.object_id.iter().all(|&id| id == 0 || id == 1));
    let (w, h) = (img.width, img.height);
    let iz = |x: u32, y: u32| 1.0 / img.z[img.index(x, y)] as f64;
    // The teapot is faceted: a sample's face slope equals the backward or the
    // forward difference (whichever neighbour lies on the same face), or
    // roughly their mean on a smooth stretch. Skip silhouettes, where the two
    // differences disagree wildly.
    let (mut smooth, mut agree) = (0, 0);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = img.index(x, y);
            let around = [img.index(x - 1, y), img.index(x + 1, y), img.index(x, y - 1), img.index(x, y + 1)];
            if !img.valid[i] || around.iter().any(|&j| !img.valid[j]) {
                continue;
            }
            let (bx, fx) = (iz(x, y) - iz(x - 1, y), iz(x + 1, y) - iz(x, y));
            let (by, fy) = (iz(x, y) - iz(x, y - 1), iz(x, y + 1) - iz(x, y));
            let scale = bx.abs().max(fx.abs()).max(by.abs()).max(fy.abs()).max(1e-5);
            if (bx - fx).abs() > 0.5 * scale || (by - fy).abs() > 0.5 * scale {
                continue;
            }
            smooth += 1;
            let s = img.inv_z_slopes[i];
            let ok =
                |b: f64, f: f64, s: f32| [b, f, 0.5 * (b + f)].iter().any(|fd| (fd - s as f64).abs() <= 0.1 * scale);
            if ok(bx, fx, s[0]) && ok(by, fy, s[1]) {
                agree += 1;
            }
        }
    }
    assert!(smooth > 1500, "{smooth}");
    assert!(agree as f64 >= 0.95 * smooth as f64, "{agree} of {smooth} agree");
}

#[test]
fn every_builtin_scene_renders_from_its_spline_start() {
    for &name in Scene::builtin_names() {
        let s = Scene::builtin(name).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.name, name);
        assert!(!s.description.is_empty());
        assert!(s.spline.waypoints.len() >= 2 && s.spline.duration_s > 0.0);
        assert!(s.tracked.scale > 0.0);
        let w = &s.spline.waypoints[0];
        let img = s.render(&camera(32, 24, 60.0, w.position, w.look_at), 1);
        let valid = img.valid.count_ones() as f64 / img.len() as f64;
        let ids: BTreeSet<u32> = img.object_id.iter().copied().filter(|&id| id > 0).collect();
        if name == "room" || name == "occluders" {
            assert!(valid > 0.9, "{name}: only {valid} valid");
        }
        assert!(ids.len() >= 3, "{name}: ids {ids:?}");
        assert!(ids.iter().all(|&id| id as usize <= s.object_count()));
        let t = &s.tracked.start;
        let img = s.render(&camera(16, 12, 60.0, t.position, t.look_at), 1);
        assert!(img.valid.count_ones() > 0, "{name}: tracked start sees nothing");
    }
}

#[test]
fn load_takes_builtin_names_and_files() {
    assert_eq!(Scene::load("slants").unwrap().name, "slants");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mine.toml");
    std::fs::write(&path, format!("[[objects]]\nkind = \"sphere\"\ncentre = [0.0, 1.0, 0.0]\nradius = 0.5\n{SPLINE}"))
        .unwrap();
    let s = Scene::load(path.to_str().unwrap()).unwrap();
    assert_eq!((s.name.as_str(), s.object_count()), ("mine", 1));
    // Defaults for [tracked]: the first waypoint, scale 1.
    assert_eq!((s.tracked.start.clone(), s.tracked.scale), (s.spline.waypoints[0].clone(), 1.0));
    let e = Scene::load("no-such-scene").unwrap_err().to_string();
    assert!(e.contains("no-such-scene") && e.contains("room"), "{e}");
    let e = Scene::builtin("kitchen").unwrap_err().to_string();
    assert!(e.contains("kitchen") && e.contains("hairball"), "{e}");
}

#[test]
fn model_paths_are_relative_to_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("models")).unwrap();
    std::fs::write(dir.path().join("models/tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let path = dir.path().join("s.toml");
    let mesh = "[[objects]]\nkind = \"mesh\"\nfile = \"models/tri.obj\"\nsize = 1.0\nposition = [0.0, 0.0, 0.0]\n";
    std::fs::write(&path, format!("{mesh}{SPLINE}")).unwrap();
    let s = Scene::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
    let img = s.render(&camera(16, 12, 30.0, DVec3::new(0.0, 0.3, 2.0), DVec3::new(0.0, 0.3, 0.0)), 1);
    assert!(img.valid.count_ones() > 0);
    // The same text without a directory cannot find the model, and says which file it tried.
    std::fs::write(&path, format!("{}{SPLINE}", mesh.replace("models/tri.obj", "models/gone.obj"))).unwrap();
    let e = Scene::from_file(&path).unwrap_err().to_string();
    assert!(e.contains("s.toml") && e.contains("gone.obj") && e.contains("line 1"), "{e}");
}

#[test]
fn scene_errors_name_the_file_key_and_expectation() {
    let dir = tempfile::tempdir().unwrap();
    // Missing file.
    let missing = dir.path().join("absent.toml");
    let e = Scene::from_file(&missing).unwrap_err().to_string();
    assert!(e.contains("absent.toml"), "{e}");
    // Unknown key, in a file: names the file, the key and the line.
    let path = dir.path().join("typo.toml");
    std::fs::write(
        &path,
        format!("[[objects]]\nkind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 1.0\nradiuss = 2.0\n{SPLINE}"),
    )
    .unwrap();
    let e = Scene::from_file(&path).unwrap_err().to_string();
    assert!(e.contains("typo.toml") && e.contains("radiuss") && e.contains("line"), "{e}");
    // Unknown top-level key.
    let e = scene_err(&format!("colour_space = \"srgb\"\n{SPLINE}"));
    assert!(e.contains("inline.toml") && e.contains("colour_space"), "{e}");
    // Bad TOML syntax.
    let e = scene_err("name = \n");
    assert!(e.contains("inline.toml") && e.contains("line 1"), "{e}");
    // Missing model.
    let e = scene_err(&format!(
        "[[objects]]\nkind = \"mesh\"\nfile = \"bundled:dragon.obj\"\nsize = 1.0\nposition = [0.0, 0.0, 0.0]\n{SPLINE}"
    ));
    assert!(e.contains("dragon.obj") && e.contains("bundled:teapot.obj"), "{e}");
    // Non-positive radius, size; zero-length axis and rod.
    let cases = [
        ("kind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = -1.0", "radius"),
        ("kind = \"mesh\"\nfile = \"bundled:cow.obj\"\nsize = 0.0\nposition = [0.0, 0.0, 0.0]", "size"),
        ("kind = \"cylinder\"\nbase = [0.0, 0.0, 0.0]\naxis = [0.0, 0.0, 0.0]\nradius = 1.0\nheight = 1.0", "axis"),
        ("kind = \"rod\"\nfrom = [1.0, 0.0, 0.0]\nto = [1.0, 0.0, 0.0]\nradius = 0.1", "zero-length"),
        ("kind = \"box\"\ncentre = [0.0, 0.0, 0.0]\nhalf_size = [1.0, 0.0, 1.0]", "half_size"),
        ("kind = \"plane\"\ncentre = [0.0, 0.0, 0.0]\nhalf_u = [1.0, 0.0, 0.0]\nhalf_v = [2.0, 0.0, 0.0]", "parallel"),
        ("kind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"gold\"", "gold"),
        ("kind = \"torus\"\ncentre = [0.0, 0.0, 0.0]", "torus"),
    ];
    for (object, expect) in cases {
        let e = scene_err(&format!("\n[[objects]]\n{object}\n{SPLINE}"));
        assert!(e.contains("inline.toml") && e.contains(expect) && e.contains("line"), "{expect}: {e}");
    }
    // Fewer than 2 waypoints.
    let one =
        "[spline]\nduration_s = 3.0\n[[spline.waypoints]]\nposition = [0.0, 1.0, 0.0]\nlook_at = [0.0, 1.0, -1.0]\n";
    let e = scene_err(one);
    assert!(e.contains("at least 2 waypoints"), "{e}");
    // No [spline] at all.
    let e = scene_err("name = \"x\"\n");
    assert!(e.contains("spline"), "{e}");
    // Bad texture parameters and colour ranges.
    let e = scene_err(&format!(
        "[materials.m]\ncolour = [0.5, 0.5, 0.5]\ntexture = {{ kind = \"checker\", cell = 0.0, colour = [0.0, 0.0, 0.0] }}\n{SPLINE}"
    ));
    assert!(e.contains("material `m`") && e.contains("cell"), "{e}");
    let e = scene_err(&format!("background = [2.0, 0.0, 0.0]\n{SPLINE}"));
    assert!(e.contains("background") && e.contains("[0, 1]"), "{e}");
    // Image texture on a sphere: no texture coordinates.
    let e = scene_err(&format!(
        "[materials.s]\ncolour = [1.0, 1.0, 1.0]\ntexture = {{ kind = \"image\", file = \"bundled:spot_texture.png\" }}\n\
         [[objects]]\nkind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"s\"\n{SPLINE}"
    ));
    assert!(e.contains("texture coordinates"), "{e}");
}

/// Render the built-in scenes from their spline start at 160x120 (ss = 2,
/// box-filtered) into `docs/img/scene-<name>.png`.
#[test]
#[ignore]
fn write_scene_previews() {
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/img");
    for &name in Scene::builtin_names() {
        let s = Scene::builtin(name).unwrap();
        let w = &s.spline.waypoints[0];
        let ss = 2;
        let img = s.render(&camera(160, 120, 60.0, w.position, w.look_at), ss);
        let px = postwarp::picture::box_filter(img.width, img.height, ss, &img.colour);
        let path = out.join(format!("scene-{name}.png"));
        postwarp::picture::write_png(&path, 160, 120, &px).unwrap();
        println!(
            "{}: {} objects, {:.1}% valid",
            path.display(),
            s.object_count(),
            100.0 * img.valid.count_ones() as f64 / img.len() as f64
        );
    }
}

#[test]
fn identity_orientation_camera_sees_the_plane_too() {
    // A camera built by hand (no look_at): z forward, y down.
    let s = scene(
        "[[objects]]\nkind = \"plane\"\ncentre = [0.0, 0.0, 3.0]\nhalf_u = [9.0, 0.0, 0.0]\nhalf_v = [0.0, 9.0, 0.0]\n",
    );
    let cam = Camera {
        intrinsics: Intrinsics::from_hfov(8, 6, 60.0),
        pose: Pose { position: DVec3::ZERO, orientation: DQuat::IDENTITY },
    };
    let img = s.render(&cam, 1);
    assert!(img.z.iter().all(|&z| z == 3.0));
}
