//! MagicaVoxel `.vox` scene graphs: instancing, the 48 signed axis
//! permutations of `_r` (the 24 rotations and their mirror images) on odd
//! and even model sizes, nested groups, hidden layers and nodes, keyframes,
//! and the 0.98 animation layout. Two independent references: the `dot_vox`
//! crate's parse of the same bytes, placed here with float matrices from
//! its own `Rotation` decoding (`reference`), and the conformance corpus's
//! answers (`tests/data/formats/vox_gltf_expected.json`, written by
//! `make_vox_gltf.py` with its own placement code).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::scratch::temp_dir;
use glam::{DMat3, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::VoxkitError;
use voxkit::grid::MemoryLimit;
use voxkit::io::vox;

fn corpus(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/formats")
        .join(rel)
}

fn expected() -> serde_json::Value {
    let s = std::fs::read_to_string(corpus("vox_gltf_expected.json")).unwrap();
    serde_json::from_str(&s).unwrap()
}

/// voxkit's voxels in world voxel coordinates (grid index + the frame's
/// origin, which a file without voxkit's attributes gets in voxel units).
fn ours(bytes: &[u8]) -> (BTreeSet<[i32; 3]>, Vec<String>) {
    let s = vox::read_colored(bytes, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(s.frame.voxel_size, 1.0);
    let o = s.frame.origin.as_ivec3();
    assert_eq!(o.as_dvec3(), s.frame.origin);
    let set: BTreeSet<[i32; 3]> = s.grid.iter().map(|v| (v + o).to_array()).collect();
    // The colour list places the same voxels.
    let listed: BTreeSet<[i32; 3]> = s
        .colors
        .voxels
        .iter()
        .map(|(v, _)| (*v + o).to_array())
        .collect();
    assert_eq!(set, listed);
    (set, s.warnings)
}

fn attr_is(d: &Dict, k: &str, v: &str) -> bool {
    d.get(k).is_some_and(|x| x == v)
}

/// The scene as `dot_vox` parses it, placed independently: each shape's
/// model (the keyframe with the smallest `_f`) under the composition of its
/// `nTRN` frames (smallest `_f`; `dot_vox`'s `Rotation` matrix and
/// position), skipping hidden nodes and nodes on hidden layers. A voxel `l`
/// of a model of size `s` is the cube centred at `l + ½ − ⌊s/2⌋`; it lands
/// in the world cell `⌊M·centre⌋` (ogt_vox's pivot rule, as vengi applies it).
fn reference(bytes: &[u8]) -> BTreeSet<[i32; 3]> {
    let data = dot_vox::load_bytes(bytes).unwrap();
    let mut out = BTreeSet::new();
    if data.scenes.is_empty() {
        for v in &data.models[0].voxels {
            out.insert([v.x as i32, v.y as i32, v.z as i32]);
        }
        return out;
    }
    let mut stack = vec![(0usize, DMat3::IDENTITY, DVec3::ZERO)];
    while let Some((id, r, t)) = stack.pop() {
        match &data.scenes[id] {
            dot_vox::SceneNode::Transform {
                attributes,
                frames,
                child,
                layer_id,
            } => {
                if attr_is(attributes, "_hidden", "1")
                    || data
                        .layers
                        .get(*layer_id as usize)
                        .is_some_and(|l| l.hidden())
                {
                    continue;
                }
                let f = frames
                    .iter()
                    .min_by_key(|f| f.frame_index().unwrap_or(0))
                    .unwrap();
                let rot = f.orientation().map_or(DMat3::IDENTITY, |o| {
                    let c = o.to_cols_array_2d();
                    DMat3::from_cols_array_2d(&c.map(|col| col.map(f64::from)))
                });
                let p = f.position().map_or(DVec3::ZERO, |p| {
                    DVec3::new(p.x as f64, p.y as f64, p.z as f64)
                });
                stack.push((*child as usize, r * rot, r * p + t));
            }
            dot_vox::SceneNode::Group { children, .. } => {
                stack.extend(children.iter().map(|&c| (c as usize, r, t)));
            }
            dot_vox::SceneNode::Shape { models, .. } => {
                let m = models
                    .iter()
                    .min_by_key(|m| m.frame_index().unwrap_or(0))
                    .unwrap();
                let model = &data.models[m.model_id as usize];
                let s = &model.size;
                let pivot = DVec3::new((s.x / 2) as f64, (s.y / 2) as f64, (s.z / 2) as f64);
                for v in &model.voxels {
                    let c = DVec3::new(v.x as f64, v.y as f64, v.z as f64) + 0.5 - pivot;
                    let w = (r * c + t).floor();
                    out.insert([w.x as i32, w.y as i32, w.z as i32]);
                }
            }
        }
    }
    out
}

// -------------------------------------------------------- writing scenes

type Dict = dot_vox::Dict;

fn dict(pairs: &[(&str, String)]) -> Dict {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.clone()))
        .collect()
}

fn model(size: [u32; 3], voxels: &[[u8; 3]]) -> dot_vox::Model {
    dot_vox::Model {
        size: dot_vox::Size {
            x: size[0],
            y: size[1],
            z: size[2],
        },
        voxels: voxels
            .iter()
            .map(|v| dot_vox::Voxel {
                x: v[0],
                y: v[1],
                z: v[2],
                i: 1,
            })
            .collect(),
    }
}

fn data(
    models: Vec<dot_vox::Model>,
    scenes: Vec<dot_vox::SceneNode>,
    layers: Vec<Dict>,
) -> Vec<u8> {
    let d = dot_vox::DotVoxData {
        version: 150,
        index_map: dot_vox::DEFAULT_INDEX_MAP.to_vec(),
        models,
        palette: dot_vox::DEFAULT_PALETTE.to_vec(),
        materials: vec![],
        scenes,
        layers: layers
            .into_iter()
            .map(|attributes| dot_vox::Layer { attributes })
            .collect(),
    };
    let mut bytes = Vec::new();
    d.write_vox(&mut bytes).unwrap();
    bytes
}

fn trn(child: u32, layer: u32, frames: Vec<Dict>, attributes: Dict) -> dot_vox::SceneNode {
    dot_vox::SceneNode::Transform {
        attributes,
        frames: frames.into_iter().map(dot_vox::Frame::new).collect(),
        child,
        layer_id: layer,
    }
}

fn frame(t: [i32; 3], r: Option<u8>) -> Dict {
    let mut d = dict(&[("_t", format!("{} {} {}", t[0], t[1], t[2]))]);
    if let Some(r) = r {
        d.insert("_r".into(), r.to_string());
    }
    d
}

fn shp(models: &[(u32, Option<u32>)]) -> dot_vox::SceneNode {
    dot_vox::SceneNode::Shape {
        attributes: Dict::new(),
        models: models
            .iter()
            .map(|&(model_id, f)| dot_vox::ShapeModel {
                model_id,
                attributes: f.map_or_else(Dict::new, |f| dict(&[("_f", f.to_string())])),
            })
            .collect(),
    }
}

fn grp(children: Vec<u32>) -> dot_vox::SceneNode {
    dot_vox::SceneNode::Group {
        attributes: Dict::new(),
        children,
    }
}

/// Every valid `_r` byte: rows 0 and 1 pick distinct columns, any signs.
fn rotation_bytes() -> Vec<u8> {
    let mut out = Vec::new();
    for a0 in 0..3u8 {
        for a1 in 0..3u8 {
            if a0 != a1 {
                for s in 0..8u8 {
                    out.push(a0 | (a1 << 2) | (s << 4));
                }
            }
        }
    }
    out
}

fn random_model(rng: &mut ChaCha8Rng) -> dot_vox::Model {
    let size = [0; 3].map(|_| rng.random_range(1..=7u32));
    let n = rng.random_range(1..=12);
    let mut v: Vec<[u8; 3]> = (0..n)
        .map(|_| size.map(|s| rng.random_range(0..s) as u8))
        .collect();
    v.sort_unstable();
    v.dedup();
    model(size, &v)
}

// ---------------------------------------------------------------- tests

/// Each of the 48 signed permutations on its own, odd and even sizes per
/// axis: voxkit places exactly the voxels the reference does. (Before: any
/// `_r` other than identity was refused.)
#[test]
fn every_rotation_on_odd_and_even_sizes_matches_dot_vox() {
    let voxels: &[[u8; 3]] = &[
        [0, 0, 0],
        [2, 0, 0],
        [0, 1, 0],
        [0, 0, 3],
        [1, 1, 2],
        [2, 1, 3],
    ];
    for size in [[3, 2, 4], [4, 3, 5], [3, 5, 7], [4, 2, 6]] {
        for r in rotation_bytes() {
            let bytes = data(
                vec![model(size, voxels)],
                vec![
                    trn(1, 0, vec![Dict::new()], Dict::new()),
                    grp(vec![2]),
                    trn(3, 0, vec![frame([5, -7, 2], Some(r))], Dict::new()),
                    shp(&[(0, None)]),
                ],
                vec![Dict::new()],
            );
            let (got, warnings) = ours(&bytes);
            assert_eq!(got, reference(&bytes), "size {size:?}, _r = {r}");
            assert!(warnings.is_empty());
            assert_eq!(got.len(), voxels.len());
        }
    }
}

/// Pinned by hand (not by agreement with a reference): a 3×2×1 model turned
/// 90° about z (`_r` rows (0,−1,0), (1,0,0), (0,0,1): column 1 with sign −
/// in row 0, column 0 in row 1, i.e. byte 1 | 0<<2 | 1<<4 = 17) at `_t` 0.
/// Pivot (1, 1, 0); voxel (0,0,0) is the cube [−1,0]×[−1,0]×[0,1], turned to
/// [0,1]×[−1,0]×[0,1]: cell (0, −1, 0). Voxel (2,1,0) is [1,2]×[0,1]×[0,1],
/// turned to [−1,0]×[1,2]×[0,1]: cell (−1, 1, 0).
#[test]
fn quarter_turn_about_z_by_hand() {
    let bytes = data(
        vec![model([3, 2, 1], &[[0, 0, 0], [2, 1, 0]])],
        vec![
            trn(1, 0, vec![Dict::new()], Dict::new()),
            grp(vec![2]),
            trn(3, 0, vec![frame([0, 0, 0], Some(17))], Dict::new()),
            shp(&[(0, None)]),
        ],
        vec![Dict::new()],
    );
    let (got, _) = ours(&bytes);
    assert_eq!(got, BTreeSet::from([[0, -1, 0], [-1, 1, 0]]));
}

/// Random scene graphs: nested groups, instanced models, rotations at every
/// level, hidden nodes, hidden layers, keyframes out of order, shapes with
/// several (keyframed) models. voxkit == dot_vox-based reference, and a
/// warning exactly when something was skipped.
#[test]
fn random_scene_graphs_match_dot_vox() {
    let rots = rotation_bytes();
    for seed in 0..60u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let models: Vec<dot_vox::Model> = (0..rng.random_range(1..4))
            .map(|_| random_model(&mut rng))
            .collect();
        let n_layers = rng.random_range(1..4u32);
        let layers: Vec<Dict> = (0..n_layers)
            .map(|l| {
                if l > 0 && rng.random_bool(0.4) {
                    dict(&[("_hidden", "1".into())])
                } else {
                    Dict::new()
                }
            })
            .collect();
        let hidden_layer = |l: u32| layers[l as usize].contains_key("_hidden");
        let mut scenes: Vec<Option<dot_vox::SceneNode>> = vec![None, None];
        let mut skipped = false;
        // Builds a subtree under a fresh nTRN; returns the nTRN's id.
        #[allow(clippy::too_many_arguments)]
        fn build(
            rng: &mut ChaCha8Rng,
            scenes: &mut Vec<Option<dot_vox::SceneNode>>,
            depth: u32,
            n_models: u32,
            n_layers: u32,
            rots: &[u8],
            skipped: &mut bool,
            hidden_layer: &dyn Fn(u32) -> bool,
        ) -> u32 {
            let tid = scenes.len() as u32;
            scenes.push(None);
            let cid = scenes.len() as u32;
            scenes.push(None);
            let n_frames = if rng.random_bool(0.2) { 3 } else { 1 };
            let frames: Vec<Dict> = (0..n_frames)
                .map(|k| {
                    let mut f = frame(
                        [0; 3].map(|_| rng.random_range(-12..12)),
                        rng.random_bool(0.7)
                            .then(|| rots[rng.random_range(0..rots.len())]),
                    );
                    if n_frames > 1 {
                        f.insert("_f".into(), ((k + 1) * 7 % 3 * 10).to_string());
                    }
                    f
                })
                .collect();
            let hidden = rng.random_bool(0.1);
            let layer = rng.random_range(0..n_layers);
            let attrs = if hidden {
                dict(&[("_hidden", "1".into())])
            } else {
                Dict::new()
            };
            let visible = !hidden && !hidden_layer(layer);
            if !visible || n_frames > 1 {
                *skipped = true;
            }
            scenes[tid as usize] = Some(trn(cid, layer, frames, attrs));
            if depth < 3 && rng.random_bool(0.4) {
                let kids: Vec<u32> = (0..rng.random_range(1..4))
                    .map(|_| {
                        build(
                            rng,
                            scenes,
                            depth + 1,
                            n_models,
                            n_layers,
                            rots,
                            skipped,
                            hidden_layer,
                        )
                    })
                    .collect();
                scenes[cid as usize] = Some(grp(kids));
            } else {
                let k = if rng.random_bool(0.2) { 2 } else { 1 };
                if k > 1 && visible {
                    *skipped = true;
                }
                let ms: Vec<(u32, Option<u32>)> = (0..k)
                    .map(|j| (rng.random_range(0..n_models), (k > 1).then_some(9 - 4 * j)))
                    .collect();
                scenes[cid as usize] = Some(shp(&ms));
            }
            tid
        }
        let kids: Vec<u32> = (0..rng.random_range(1..5))
            .map(|_| {
                build(
                    &mut rng,
                    &mut scenes,
                    0,
                    models.len() as u32,
                    n_layers,
                    &rots,
                    &mut skipped,
                    &hidden_layer,
                )
            })
            .collect();
        scenes[0] = Some(trn(1, u32::MAX, vec![Dict::new()], Dict::new()));
        scenes[1] = Some(grp(kids));
        let scenes: Vec<dot_vox::SceneNode> = scenes.into_iter().map(Option::unwrap).collect();
        let bytes = data(models, scenes, layers);
        let want = reference(&bytes);
        match vox::read_colored(&bytes, MemoryLimit::DEFAULT) {
            Ok(_) => {
                let (got, warnings) = ours(&bytes);
                assert_eq!(got, want, "seed {seed}");
                // A hidden subtree inside a hidden one is not reached, so a
                // skip may go unreported only when nothing else is visible
                // of it; a warning always means something was skipped.
                if !warnings.is_empty() {
                    assert!(skipped, "seed {seed}: {warnings:?}");
                }
            }
            Err(e) => {
                assert!(want.is_empty(), "seed {seed}: {e}");
                assert!(e.to_string().contains("nothing is visible"), "{e}");
            }
        }
    }
}

/// One model placed by several shape nodes is placed at every one of them
/// (before: only the last placement survived).
#[test]
fn instanced_model_is_placed_at_every_node() {
    let voxels: &[[u8; 3]] = &[[0, 0, 0], [1, 0, 0], [1, 1, 2]];
    let places = [[0, 0, 0], [20, 0, 0], [0, 30, -4], [7, 7, 7]];
    let mut scenes = vec![
        trn(1, 0, vec![Dict::new()], Dict::new()),
        grp((0..places.len() as u32).map(|i| 2 + 2 * i).collect()),
    ];
    for (i, t) in places.iter().enumerate() {
        scenes.push(trn(3 + 2 * i as u32, 0, vec![frame(*t, None)], Dict::new()));
        scenes.push(shp(&[(0, None)]));
    }
    let bytes = data(vec![model([2, 2, 3], voxels)], scenes, vec![Dict::new()]);
    let (got, _) = ours(&bytes);
    assert_eq!(got.len(), voxels.len() * places.len());
    assert_eq!(got, reference(&bytes));
}

/// The 0.98 layout (several models, no scene graph): the models are
/// animation frames; frame 0 is read, with a warning (before: all frames
/// were drawn on top of each other).
#[test]
fn models_without_scene_graph_are_animation_frames() {
    let bytes = data(
        vec![
            model([3, 3, 3], &[[0, 0, 0], [2, 2, 2]]),
            model([3, 3, 3], &[[1, 1, 1]]),
            model([3, 3, 3], &[[0, 2, 0]]),
        ],
        vec![],
        vec![],
    );
    let (got, warnings) = ours(&bytes);
    assert_eq!(got, BTreeSet::from([[0, 0, 0], [2, 2, 2]]));
    assert_eq!(warnings.len(), 1);
    assert!(warnings[0].contains("animation frames"), "{warnings:?}");
    // One model: nothing to warn about.
    let one = data(vec![model([3, 3, 3], &[[1, 1, 1]])], vec![], vec![]);
    assert!(ours(&one).1.is_empty());
}

/// Hidden layers and hidden nodes are skipped (the editor does not show
/// them), each named in one warning; a scene with nothing visible is one
/// clear error.
#[test]
fn hidden_layers_and_nodes_are_skipped_with_warnings() {
    let m = || model([1, 1, 1], &[[0, 0, 0]]);
    let scene = |hidden_node: bool, layer1_hidden: bool| {
        let mut hidden = Dict::new();
        if hidden_node {
            hidden.insert("_hidden".into(), "1".into());
        }
        let mut l1 = dict(&[("_name", "backdrop".into())]);
        if layer1_hidden {
            l1.insert("_hidden".into(), "1".into());
        }
        data(
            vec![m()],
            vec![
                trn(1, u32::MAX, vec![Dict::new()], Dict::new()),
                grp(vec![2, 4]),
                trn(3, 0, vec![frame([0, 0, 0], None)], hidden),
                shp(&[(0, None)]),
                trn(5, 1, vec![frame([5, 0, 0], None)], Dict::new()),
                shp(&[(0, None)]),
            ],
            vec![Dict::new(), l1],
        )
    };
    let (all, w) = ours(&scene(false, false));
    assert_eq!(all.len(), 2);
    assert!(w.is_empty());
    let (got, w) = ours(&scene(true, false));
    assert_eq!(got, BTreeSet::from([[5, 0, 0]]));
    assert_eq!(w.len(), 1);
    assert!(w[0].contains("hidden node 2"), "{w:?}");
    let (got, w) = ours(&scene(false, true));
    assert_eq!(got, BTreeSet::from([[0, 0, 0]]));
    assert_eq!(
        w,
        vec![r#"skipped hidden layer 1 ("backdrop")"#.to_string()]
    );
    let err = vox::read(&scene(true, true), MemoryLimit::DEFAULT).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, VoxkitError::Invalid(_)));
    assert!(
        msg.contains("nothing is visible") && msg.contains("hidden layer 1"),
        "{msg}"
    );
    assert_eq!(msg.lines().count(), 1);
}

/// Keyframes: an animated nTRN is read at its first keyframe (smallest
/// `_f`, whatever the order in the file), an nSHP with several models shows
/// the first keyframe's model; each is warned about.
#[test]
fn keyframes_read_frame_zero() {
    let bytes = data(
        vec![
            model([1, 1, 1], &[[0, 0, 0]]),
            model([2, 1, 1], &[[1, 0, 0]]),
        ],
        vec![
            trn(1, u32::MAX, vec![Dict::new()], Dict::new()),
            grp(vec![2]),
            trn(
                3,
                0,
                vec![
                    dict(&[("_f", "8".into()), ("_t", "90 90 90".into())]),
                    dict(&[("_f", "0".into()), ("_t", "4 5 6".into())]),
                ],
                Dict::new(),
            ),
            shp(&[(0, Some(3)), (1, Some(0))]),
        ],
        vec![Dict::new()],
    );
    let (got, w) = ours(&bytes);
    assert_eq!(got, reference(&bytes));
    // Model 1 (size 2, pivot 1): voxel 1 lands at 4 + 1 - 1.
    assert_eq!(got, BTreeSet::from([[4, 5, 6]]));
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(w[0].contains("animated transforms in node 2"), "{w:?}");
    assert!(w[1].contains("animated shapes in node 3"), "{w:?}");
}

/// Broken scene graphs are one-line typed errors naming the chunk and node.
#[test]
fn broken_scene_graphs_are_one_line_errors() {
    let m = || vec![model([2, 2, 2], &[[0, 0, 0]])];
    let base = |r: &str| {
        data(
            m(),
            vec![
                trn(1, 0, vec![Dict::new()], Dict::new()),
                grp(vec![2]),
                trn(3, 0, vec![dict(&[("_r", r.into())])], Dict::new()),
                shp(&[(0, None)]),
            ],
            vec![Dict::new()],
        )
    };
    for r in ["3", "5", "15", "128", "-1", "x"] {
        let e = vox::read(&base(r), MemoryLimit::DEFAULT)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("nTRN node 2") && e.contains("rotation"),
            "{r}: {e}"
        );
        assert_eq!(e.lines().count(), 1);
    }
    // A shared node (two groups listing the same child) and a cycle.
    for kids in [vec![2, 2], vec![0]] {
        let bytes = data(
            m(),
            vec![
                trn(1, 0, vec![Dict::new()], Dict::new()),
                grp(kids),
                trn(3, 0, vec![Dict::new()], Dict::new()),
                shp(&[(0, None)]),
            ],
            vec![Dict::new()],
        );
        let e = vox::read(&bytes, MemoryLimit::DEFAULT)
            .unwrap_err()
            .to_string();
        assert!(e.contains("reached twice"), "{e}");
    }
}

/// The committed corpus (tests/data/formats/vox): voxkit, the dot_vox
/// reference and the generator's own answers agree, and the warnings name
/// what the generator skipped.
#[test]
fn corpus_matches_its_answers_and_dot_vox() {
    let exp = expected();
    let files = exp["vox"].as_object().unwrap();
    assert!(files.len() >= 7);
    for (name, want) in files {
        let bytes = std::fs::read(corpus(&format!("vox/{name}"))).unwrap();
        let (got, warnings) = ours(&bytes);
        let answer: BTreeSet<[i32; 3]> = want["voxels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| {
                let a: Vec<i32> = v
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_i64().unwrap() as i32)
                    .collect();
                [a[0], a[1], a[2]]
            })
            .collect();
        assert_eq!(got, answer, "{name}");
        assert_eq!(got, reference(&bytes), "{name}");
        let expect_w: Vec<&str> = want["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap())
            .collect();
        for w in &expect_w {
            assert!(
                warnings.iter().any(|x| x.contains(w)),
                "{name}: {w:?} not in {warnings:?}"
            );
        }
        assert_eq!(
            expect_w.is_empty(),
            warnings.is_empty(),
            "{name}: {warnings:?}"
        );
    }
}

/// The command line prints each warning as one `warning:` line on stderr
/// and lists them under `warnings` in `--json` (check, render).
#[test]
fn cli_prints_vox_warnings() {
    let dir = temp_dir("vox-scene");
    let input = corpus("vox/hidden.vox");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(["check", input.to_str().unwrap(), "--tunnels", "6"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(
        lines
            .iter()
            .all(|l| l.starts_with("warning: ") && l.contains("hidden.vox")),
        "{err}"
    );
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["warnings"].as_array().unwrap().len(), 2, "{j}");
    let png = dir.join("h.png");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args([
            "render",
            input.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--size",
            "16x16",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["warnings"].as_array().unwrap().len(), 2, "{j}");
    let _ = std::fs::remove_dir_all(&dir);
}
