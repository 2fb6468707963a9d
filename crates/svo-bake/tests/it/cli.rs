//! End-to-end tests of the `svo-bake` binary on the real meshes (`SVO_MODELS`) and on
//! bad input: every failure exits non-zero with one clear line and leaves no output file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use svo_tests::harness::{Need, Test};
use svo_tests::trial;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_svo-bake"))
}

/// The mesh whose presence stands for the shared models.
const BUNNY: &str = "stanford/stanford-bunny.obj";

/// The shared models folder (`SVO_MODELS`, else `../shared/models`), when the bunny is in
/// it (the tests that call this need [`BUNNY`]).
fn models() -> Option<PathBuf> {
    svo_tests::model("stanford/stanford-bunny.obj")?;
    Some(svo_tests::models_dir())
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("run svo-bake")
}

fn ok(args: &[&str]) -> String {
    let o = run(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "svo-bake {args:?} failed: {err}");
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs and expects a clean failure whose message contains `needle`.
fn fails(args: &[&str], needle: &str) {
    let o = run(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "svo-bake {args:?} succeeded");
    assert!(!err.contains("panicked"), "panic: {err}");
    assert!(err.starts_with("svo-bake: error: "), "unclear error: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
    assert!(
        err.to_lowercase().contains(&needle.to_lowercase()),
        "{args:?}: expected {needle:?} in {err}"
    );
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn read_tree(p: &Path) -> svo::Octree {
    svo::io::read_file(p).unwrap().0
}

fn bakes_bunny_obj_and_ply_and_prints_summary() {
    let Some(m) = models() else { return };
    let d = tmp();
    let out = d.path().join("bunny.svo");
    let text = ok(&[
        s(&m.join("stanford/stanford-bunny.obj")),
        "--depth",
        "6",
        "-o",
        s(&out),
    ]);
    for field in [
        "triangles",
        "69451",
        "leaves",
        "bytes per leaf",
        "voxelize",
        "attributes",
        "contours",
        "write",
    ] {
        assert!(text.contains(field), "summary lacks {field}: {text}");
    }
    let obj = read_tree(&out);
    let out2 = d.path().join("bunny_ply.svo");
    ok(&[
        s(&m.join("stanford/bun_zipper.ply")),
        "--depth",
        "6",
        "-o",
        s(&out2),
        "-q",
    ]);
    let ply = read_tree(&out2);
    // The OBJ is the PLY rounded to 6 decimals: the same cells up to rare contacts.
    let diff = (i64::from(obj.leaf_count) - i64::from(ply.leaf_count)).abs();
    assert!(
        diff * 200 < i64::from(obj.leaf_count),
        "{} vs {}",
        obj.leaf_count,
        ply.leaf_count
    );
}

fn gltf_variants_give_the_same_cells() {
    let Some(m) = models() else { return };
    let d = tmp();
    let mut trees = Vec::new();
    for f in [
        "gltf/Box.glb",
        "gltf/Box_glTF/Box.gltf",
        "gltf/Box-Embedded.gltf",
    ] {
        let out = d.path().join("box.svo");
        ok(&[s(&m.join(f)), "--depth", "5", "-o", s(&out), "-q"]);
        trees.push(read_tree(&out));
    }
    let cells = |t: &svo::Octree| t.leaves().map(|l| l.cell).collect::<Vec<_>>();
    assert_eq!(cells(&trees[0]), cells(&trees[1]));
    assert_eq!(cells(&trees[0]), cells(&trees[2]));
    // A closed unit box that is its own root: exactly the boundary shell of the 32^3 grid.
    assert_eq!(trees[0].leaf_count, 32 * 32 * 32 - 30 * 30 * 30);
}

fn textured_and_transmissive_gltf_get_per_leaf_channels() {
    let Some(m) = models() else { return };
    let d = tmp();
    let out = d.path().join("t.svo");
    let j = ok(&[
        s(&m.join("gltf/TransmissionTest.glb")),
        "--depth",
        "6",
        "-o",
        s(&out),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&j).unwrap();
    let ch = v["bake"]["channels"].to_string();
    assert!(
        ch.contains("[\"colour\",\"per-leaf\"]") && ch.contains("[\"refractivity\",\"per-leaf\"]"),
        "{ch}"
    );
    let out = d.path().join("h.svo");
    ok(&[
        s(&m.join("gltf/DamagedHelmet.glb")),
        "--depth",
        "6",
        "-o",
        s(&out),
        "-q",
    ]);
    let t = read_tree(&out);
    assert!(t.attributes.colour.is_per_leaf());
}

fn gzipped_dragon_bakes() {
    let Some(m) = models() else { return };
    let d = tmp();
    let out = d.path().join("dragon.svo");
    let j = ok(&[
        s(&m.join("stanford/dragon_vrip_res2.obj.gz")),
        "--depth",
        "7",
        "-o",
        s(&out),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&j).unwrap();
    assert_eq!(v["bake"]["triangles"], 202_520);
    assert_eq!(
        u64::from(read_tree(&out).leaf_count),
        v["leaves"].as_u64().unwrap()
    );
}

fn exports_hold_exactly_the_octree_cells() {
    let Some(m) = models() else { return };
    let d = tmp();
    let svo_path = d.path().join("b.svo");
    ok(&[
        s(&m.join("stanford/stanford-bunny.obj")),
        "--depth",
        "6",
        "-o",
        s(&svo_path),
        "-q",
    ]);
    let tree = read_tree(&svo_path);
    let mut cells: Vec<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
    cells.sort_unstable();
    // Direct export and conversion from .svo give the same binvox.
    let bv = d.path().join("b.binvox");
    ok(&[
        s(&m.join("stanford/stanford-bunny.obj")),
        "--depth",
        "6",
        "-o",
        s(&bv),
        "-q",
    ]);
    let bv2 = d.path().join("c.binvox");
    ok(&[s(&svo_path), "-o", s(&bv2), "-q"]);
    let bytes = std::fs::read(&bv).unwrap();
    assert_eq!(bytes, std::fs::read(&bv2).unwrap());
    let (dim, tr, scale, mut got) = svo::io::read_binvox(&bytes).unwrap();
    got.sort_unstable();
    assert_eq!(dim, 64);
    assert_eq!(tr, tree.root.origin.to_array());
    assert_eq!(scale, tree.root.side);
    assert_eq!(got, cells);
    // MagicaVoxel: Z-up, (x, y, z) -> (x, dim - 1 - z, y).
    let vx = d.path().join("b.vox");
    ok(&[s(&svo_path), "-o", s(&vx), "-q"]);
    let data = dot_vox::load(s(&vx)).unwrap();
    let mut back: Vec<[u32; 3]> = data.models[0]
        .voxels
        .iter()
        .map(|v| [u32::from(v.x), u32::from(v.z), 63 - u32::from(v.y)])
        .collect();
    back.sort_unstable();
    assert_eq!(back, cells);
}

fn output_is_identical_for_1_2_and_8_threads_and_json_and_quiet_work() {
    let Some(m) = models() else { return };
    let d = tmp();
    let a = d.path().join("a.svo");
    let b = d.path().join("b.svo");
    let c = d.path().join("c.svo");
    let src = m.join("stanford/stanford-bunny.obj");
    ok(&[s(&src), "--depth", "8", "-o", s(&a), "--threads", "1", "-q"]);
    let quiet = ok(&[s(&src), "--depth", "8", "-o", s(&b), "--threads", "2", "-q"]);
    assert!(quiet.is_empty());
    ok(&[s(&src), "--depth", "8", "-o", s(&c), "--threads", "8", "-q"]);
    let first = std::fs::read(&a).unwrap();
    assert_eq!(first, std::fs::read(&b).unwrap(), "1 and 2 threads differ");
    assert_eq!(first, std::fs::read(&c).unwrap(), "1 and 8 threads differ");
    let j = ok(&[
        s(&src),
        "--depth",
        "4",
        "-o",
        s(&a),
        "--json",
        "--strategy",
        "aabb-plane",
        "--channels",
        "normal",
    ]);
    let v: serde_json::Value = serde_json::from_str(&j).unwrap();
    assert_eq!(v["bake"]["strategy"], "aabb-plane");
    assert_eq!(v["bake"]["exact"], false);
    assert_eq!(v["bake"]["channels"].as_array().unwrap().len(), 1);
}

fn lod_filtered_writes_version_4_with_the_same_leaves_in_memory_and_in_parts() {
    let d = tmp();
    let torus = svo_tests::repo_root().join("fixtures/torus.obj");
    let plain = d.path().join("plain.svo");
    let lod = d.path().join("lod.svo");
    ok(&[s(&torus), "--depth", "7", "-q", "-o", s(&plain)]);
    let text = ok(&[
        s(&torus),
        "--depth",
        "7",
        "--lod",
        "filtered",
        "-o",
        s(&lod),
    ]);
    assert!(text.contains("inner nodes "), "{text}");
    let version =
        |p: &Path| u32::from_le_bytes(std::fs::read(p).unwrap()[8..12].try_into().unwrap());
    assert_eq!((version(&plain), version(&lod)), (2, 4));
    let (a, b) = (read_tree(&plain), read_tree(&lod));
    // The same shape and leaves (with inner-node values the nodes are level by level).
    assert_eq!(a.attributes, b.attributes);
    assert!(svo_tests::node_order::same_shape(&a, &b));
    assert!(b.node_attributes.normal.is_per_leaf() && b.node_attributes.contour.is_per_leaf());
    // `--lod none` is the default.
    let none = d.path().join("none.svo");
    ok(&[
        s(&torus),
        "--depth",
        "7",
        "--lod",
        "none",
        "-q",
        "-o",
        s(&none),
    ]);
    assert!(std::fs::read(&none).unwrap() == std::fs::read(&plain).unwrap());
    // Bakes in parts make them too: the same bytes, within a budget and planned.
    let parts = d.path().join("parts.svo");
    let text = ok(&[
        s(&torus),
        "--depth",
        "7",
        "--lod",
        "filtered",
        "--memory",
        "8MiB",
        "-o",
        s(&parts),
    ]);
    assert!(text.contains("parts "), "{text}");
    assert!(std::fs::read(&parts).unwrap() == std::fs::read(&lod).unwrap());
    let plan = d.path().join("job.svoplan");
    ok(&[
        "plan",
        s(&torus),
        "--depth",
        "7",
        "--lod",
        "filtered",
        "--parts",
        "2",
        "-o",
        s(&plan),
    ]);
    for i in ["0", "1"] {
        ok(&["part", s(&plan), i]);
    }
    let merged = d.path().join("merged.svo");
    let text = ok(&["merge", s(&plan), "-o", s(&merged)]);
    assert!(text.contains("version 4"), "{text}");
    assert!(std::fs::read(&merged).unwrap() == std::fs::read(&lod).unwrap());
    fails(
        &["merge", s(&plan), "--chunked", "-o", s(&merged)],
        "inner-node attributes",
    );
}

/// `--layout dag` writes version 4's DAG layout: the same tree as the tree layout, smaller;
/// an `.svo` converts either way, to the other layout's bytes exactly; a bake within a memory
/// budget and a merge of a plan's parts write the DAG bake's bytes; what the layout cannot
/// hold or this kind of job does not make is one clear line and no output.
fn layout_dag_writes_the_same_tree_and_converts_both_ways() {
    let d = tmp();
    let torus = svo_tests::repo_root().join("fixtures/torus.obj");
    let p = |n: &str| d.path().join(n);
    let (tree, dag) = (p("tree.svo"), p("dag.svo"));
    ok(&[
        s(&torus),
        "--depth",
        "7",
        "--channels",
        "none",
        "-q",
        "-o",
        s(&tree),
    ]);
    ok(&[
        s(&torus),
        "--depth",
        "7",
        "--channels",
        "none",
        "--layout",
        "dag",
        "-q",
        "-o",
        s(&dag),
    ]);
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    let (t, g) = (bytes(&tree), bytes(&dag));
    assert_eq!(u32::from_le_bytes(g[8..12].try_into().unwrap()), 4);
    assert!(2 * g.len() < t.len(), "{} against {}", g.len(), t.len());
    assert_eq!(read_tree(&tree), read_tree(&dag));
    // Conversions, both ways, give the other bake's bytes.
    ok(&[s(&dag), "--layout", "tree", "-q", "-o", s(&p("back.svo"))]);
    assert!(bytes(&p("back.svo")) == t);
    ok(&[s(&tree), "--layout", "dag", "-q", "-o", s(&p("again.svo"))]);
    assert!(bytes(&p("again.svo")) == g);
    // Refused, with nothing written.
    let no = p("no.svo");
    fails(
        &[
            s(&torus),
            "--depth",
            "5",
            "--lod",
            "filtered",
            "--layout",
            "dag",
            "-o",
            s(&no),
        ],
        "inner-node attributes",
    );
    fails(
        &[s(&torus), "--depth", "1", "--layout", "dag", "-o", s(&no)],
        "depth 2 or more",
    );
    // Within a memory budget (in parts, reduced into one graph at the merge), and merged from
    // a plan's parts: the bytes of the DAG bake in memory.
    let deeper = |extra: &[&str], out: &Path| {
        let mut a = vec![s(&torus), "--depth", "9", "--channels", "normal", "-q"];
        a.extend_from_slice(extra);
        a.extend(["-o", s(out)]);
        ok(&a);
        bytes(out)
    };
    let whole = deeper(&["--layout", "dag"], &p("d9.svo"));
    let parts = deeper(&["--layout", "dag", "--memory", "16MiB"], &p("d9parts.svo"));
    assert!(
        parts == whole,
        "{} bytes against {}",
        parts.len(),
        whole.len()
    );
    let plan = p("d9.svoplan");
    ok(&[
        "plan",
        s(&torus),
        "--parts",
        "3",
        "--depth",
        "9",
        "--channels",
        "normal",
        "-o",
        s(&plan),
    ]);
    for i in ["0", "1", "2"] {
        ok(&["part", s(&plan), i]);
    }
    ok(&[
        "merge",
        s(&plan),
        "--layout",
        "dag",
        "-o",
        s(&p("d9merged.svo")),
    ]);
    assert!(bytes(&p("d9merged.svo")) == whole);
    fails(
        &[
            s(&torus),
            "--depth",
            "5",
            "--memory",
            "64MiB",
            "--lod",
            "filtered",
            "--layout",
            "dag",
            "-o",
            s(&no),
        ],
        "inner-node attributes",
    );
    fails(
        &[
            s(&torus),
            "--depth",
            "5",
            "--layout",
            "dag",
            "-o",
            s(&p("no.binvox")),
        ],
        ".svo outputs",
    );
    assert!(!no.exists() && !p("no.binvox").exists());
    // An .svo input without -o would be written over: refused, the input untouched.
    fails(&[s(&tree), "--layout", "dag"], "needs -o");
    assert!(bytes(&tree) == t);
}

/// `--layout dag --attribute-depth A --normal-bits B`: the normals kept on level A from the
/// inner nodes' attributes, in B bits, a much smaller file whose tree reads back with each
/// leaf holding its ancestor's normal; the conversion of a `--lod filtered` file gives the
/// same bytes; what cannot be kept so is refused, nothing written.
fn layout_dag_keeps_values_on_a_level() {
    let d = tmp();
    let torus = svo_tests::repo_root().join("fixtures/torus.obj");
    let p = |n: &str| d.path().join(n);
    let base = [s(&torus), "--depth", "8", "--channels", "normal", "-q"];
    let run = |extra: &[&str], out: &Path| {
        let mut a = base.to_vec();
        a.extend_from_slice(extra);
        a.extend_from_slice(&["-o", s(out)]);
        ok(&a);
    };
    let on_level = [
        "--layout",
        "dag",
        "--attribute-depth",
        "6",
        "--normal-bits",
        "16",
    ];
    run(&["--layout", "dag"], &p("leaves.svo"));
    run(&on_level, &p("level6.svo"));
    let size = |q: &Path| std::fs::metadata(q).unwrap().len();
    assert!(
        3 * size(&p("level6.svo")) < size(&p("leaves.svo")),
        "{} against {}",
        size(&p("level6.svo")),
        size(&p("leaves.svo"))
    );
    let (coarse, _) = svo::io::read_dag_file(p("level6.svo")).unwrap();
    assert_eq!(coarse.values_level(), 6);
    let (fine, _) = svo::io::read_dag_file(p("leaves.svo")).unwrap();
    assert_eq!(fine.values_level(), 8);
    assert_eq!(
        read_tree(&p("level6.svo")).nodes,
        read_tree(&p("leaves.svo")).nodes
    );
    // The conversion of a file with the inner nodes' attributes: the same bytes.
    run(&["--lod", "filtered"], &p("filtered.svo"));
    let (filtered, converted) = (p("filtered.svo"), p("converted.svo"));
    let mut convert = vec![s(&filtered)];
    convert.extend_from_slice(&on_level);
    convert.extend_from_slice(&["-q", "-o", s(&converted)]);
    ok(&convert);
    assert!(std::fs::read(p("converted.svo")).unwrap() == std::fs::read(p("level6.svo")).unwrap());
    let no = p("no.svo");
    let refused = |extra: &[&str], says: &str| {
        let mut a = base.to_vec();
        a.extend_from_slice(extra);
        a.extend_from_slice(&["-o", s(&no)]);
        fails(&a, says);
        assert!(!no.exists());
    };
    refused(&["--attribute-depth", "6"], "for --layout dag");
    refused(&["--layout", "dag", "--attribute-depth", "7"], "1 to 6");
    refused(
        &["--layout", "dag", "--normal-bits", "9"],
        "9 bits a normal",
    );
    refused(
        &["--layout", "dag", "--colour-bits", "8"],
        "8 bits a colour",
    );
    refused(&["--colour-bits", "4"], "for --layout dag");
    // Within a memory budget (parts baked with the inner nodes' attributes, the graph and
    // the level's values made by the merge), and by a plan's parts merged: the same bytes.
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    let mut within = on_level.to_vec();
    within.extend(["--memory", "16MiB"]);
    run(&within, &p("level6parts.svo"));
    assert!(bytes(&p("level6parts.svo")) == bytes(&p("level6.svo")));
    let plan = p("level6.svoplan");
    let plan_with = |extra: &[&str]| {
        let mut a = vec!["plan", s(&torus), "--parts", "3", "--depth", "8"];
        a.extend_from_slice(&["--channels", "normal", "-o", s(&plan)]);
        a.extend_from_slice(extra);
        ok(&a);
        for i in ["0", "1", "2"] {
            ok(&["part", s(&plan), i]);
        }
    };
    let merged = p("level6merged.svo");
    let mut merge = vec!["merge", s(&plan), "-o", s(&merged)];
    merge.extend_from_slice(&on_level);
    let merge_fails = |extra: &[&str], says: &str| {
        let mut a = vec!["merge", s(&plan), "-o", s(&no)];
        a.extend_from_slice(extra);
        fails(&a, says);
        assert!(!no.exists());
    };
    // Planned for the DAG with values on a level: parts without leaf channels, one merge.
    plan_with(&on_level);
    ok(&merge);
    assert!(bytes(&merged) == bytes(&p("level6.svo")));
    merge_fails(&[], "no per-leaf values");
    // Planned with the inner nodes' attributes and no contours: the same file.
    plan_with(&["--lod", "filtered", "--no-contours"]);
    std::fs::remove_file(&merged).unwrap();
    ok(&merge);
    assert!(bytes(&merged) == bytes(&p("level6.svo")));
    merge_fails(&["--attribute-depth", "6"], "for --layout dag");
    fails(
        &[
            "plan",
            s(&torus),
            "--parts",
            "3",
            "--attribute-depth",
            "6",
            "-o",
            s(&plan),
        ],
        "for --layout dag",
    );
    plan_with(&[]);
    merge_fails(&on_level, "node attributes");
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// One bad invocation: the input file (name and contents, or `None` for one that does not
/// exist), the arguments after it (`{out}` stands for the output path, `{dir}` for the
/// folder), and a phrase the one-line error must contain.
struct Bad {
    input: (&'static str, Option<&'static str>),
    args: &'static [&'static str],
    needle: &'static str,
}

const TRIANGLE: Option<&str> = Some("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
const OUT: &[&str] = &["-o", "{out}"];

const BAD_INPUT: &[Bad] = &[
    Bad {
        input: ("nope.obj", None),
        args: OUT,
        needle: "nope.obj",
    },
    Bad {
        input: ("mesh.txt", Some("hello")),
        args: OUT,
        needle: "unsupported mesh format",
    },
    Bad {
        input: ("nan.obj", Some("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")),
        args: OUT,
        needle: "non-finite",
    },
    Bad {
        input: ("inf.obj", Some("v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n")),
        args: OUT,
        needle: "non-finite",
    },
    Bad {
        input: ("idx.obj", Some("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")),
        args: OUT,
        needle: "",
    },
    Bad {
        input: ("empty.obj", Some("# nothing\n")),
        args: OUT,
        needle: "no triangles",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["-o", "{out}", "--threads", "0"],
        needle: "threads",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["-o", "{out}", "--threads", "100000"],
        needle: "threads",
    },
    Bad {
        input: (
            "bad.ply",
            Some(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                 property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                 end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
            ),
        ),
        args: OUT,
        needle: "vertex 7",
    },
    Bad {
        input: (
            "elem.ply",
            Some(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                 property float z\nend_header\n0 0 0\n1 0 0\n0 x 0\n",
            ),
        ),
        args: OUT,
        needle: "Line 10",
    },
    Bad {
        input: ("pos.obj", Some("v 0 0 0\nv 1 0 0\nv 0 y 0\nf 1 2 3\n")),
        args: OUT,
        needle: "line 3: position parse error",
    },
    Bad {
        input: (
            "trunc.ply",
            Some("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"),
        ),
        args: OUT,
        needle: "cannot parse",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["--depth", "0", "-o", "{out}"],
        needle: "depth 0",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["--depth", "31", "-o", "{out}"],
        needle: "depth 31",
    },
    // Past the memory a bake to .svo goes into parts, which are refused at their number or
    // the disk they need; other outputs are refused at the memory estimate.
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["--depth", "24", "-o", "{out}"],
        needle: "lower --depth",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["--depth", "24", "-o", "{dir}/out.binvox"],
        needle: "--force",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["--depth", "24", "--force", "-o", "{dir}/out.binvox"],
        needle: "more than one tree in memory holds",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["-o", "{dir}/no/such/dir/x.svo"],
        needle: "does not exist",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["-o", "{dir}/x.stl"],
        needle: "unsupported output",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["--depth", "11", "-o", "{dir}/x.binvox"],
        needle: "binvox holds grids up to 1024",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["--channels", "contour", "-o", "{out}"],
        needle: "normal",
    },
    Bad {
        input: ("tri.obj", TRIANGLE),
        args: &["--channels", "sparkle", "-o", "{out}"],
        needle: "unknown channel",
    },
    Bad {
        input: (
            "bad.svo",
            Some("\u{89}SVO\r\n\u{1a}\nxxxxxxxxxxxxxxxxxxxxxxxxxxxx"),
        ),
        args: &["-o", "{dir}/x.binvox"],
        needle: "",
    },
];

fn bad_input_gives_one_clear_line_and_no_output() {
    let d = tmp();
    let out = d.path().join("out.svo");
    let dir = s(d.path());
    for case in BAD_INPUT {
        let (name, text) = case.input;
        let input = match text {
            Some(text) => write(d.path(), name, text),
            None => d.path().join(name),
        };
        let mut args = vec![s(&input).to_owned()];
        args.extend(
            case.args
                .iter()
                .map(|a| a.replace("{out}", s(&out)).replace("{dir}", dir)),
        );
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails(&args, case.needle);
        assert!(!out.exists(), "{args:?} wrote an output");
    }
    // Nothing but our inputs in the folder: no partial or temporary files.
    let names: Vec<String> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names
            .iter()
            .all(|n| !n.contains(".tmp") && !n.starts_with("out") && !n.starts_with('x')),
        "{names:?}"
    );
}

fn failed_bake_keeps_the_previous_output() {
    let d = tmp();
    let out = d.path().join("keep.svo");
    let tri = write(d.path(), "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    ok(&[s(&tri), "--depth", "3", "-o", s(&out), "-q"]);
    let before = std::fs::read(&out).unwrap();
    let nan = write(
        d.path(),
        "nan.obj",
        "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n",
    );
    fails(&[s(&nan), "-o", s(&out)], "non-finite");
    assert_eq!(std::fs::read(&out).unwrap(), before);
}

/// Killing `svo-bake` at any moment (SIGKILL, no chance to clean up) leaves the previous
/// output or the complete new one, never a partial file: kills spread evenly over a bake's
/// whole run time, from before it reads its input to after it has finished.
fn killed_bake_leaves_the_old_output_or_the_whole_new_one() {
    let Some(m) = models() else { return };
    let d = tmp();
    let out = d.path().join("out.svo");
    let src = m.join("stanford/stanford-bunny.obj");
    ok(&[s(&src), "--depth", "4", "-o", s(&out), "-q"]);
    let old = std::fs::read(&out).unwrap();
    // The new output, made once undisturbed (the bake is deterministic), and its run time.
    let whole = d.path().join("whole.svo");
    let t0 = std::time::Instant::now();
    ok(&[s(&src), "--depth", "7", "-o", s(&whole), "-q"]);
    let run_time = t0.elapsed();
    let new = std::fs::read(&whole).unwrap();
    assert_ne!(old, new);
    let (mut saw_old, mut saw_new) = (0, 0);
    for k in 0..=12u32 {
        let mut child = bin()
            .args([s(&src), "--depth", "7", "-o", s(&out), "-q"])
            .spawn()
            .unwrap();
        std::thread::sleep(run_time.mul_f64(f64::from(k) / 11.0));
        let _ = child.kill();
        let _ = child.wait();
        let now = std::fs::read(&out).unwrap();
        if now == old {
            saw_old += 1;
        } else {
            assert!(
                now == new,
                "kill {k}: the output is neither the old file nor the new one"
            );
            saw_new += 1;
            std::fs::write(&out, &old).unwrap();
        }
        // Anything else left in the folder is a temporary file beside the output.
        for e in std::fs::read_dir(d.path()).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            assert!(
                name == "out.svo" || name == "whole.svo" || name.starts_with(".out.svo."),
                "unexpected file {name}"
            );
        }
    }
    assert!(
        saw_old > 0,
        "no kill landed before the rename: the test checks nothing"
    );
    eprintln!("kills: {saw_old} left the old output, {saw_new} the new one");
}

/// The glTF files on which the gltf crates panic (found by the `mesh_import` fuzz target,
/// kept in `fixtures/fuzz/mesh_import/crash-gltf-*`, whose first byte picks the format) are
/// refused with one clear line.
fn hostile_gltf_files_give_one_clear_line() {
    let d = tmp();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/fuzz/mesh_import");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if !name.starts_with("crash-gltf-") {
            continue;
        }
        let bytes = std::fs::read(&p).unwrap();
        let input = d.path().join(format!("{name}.gltf"));
        std::fs::write(&input, &bytes[1..]).unwrap();
        let out = d.path().join("out.svo");
        fails(&[s(&input), "-o", s(&out)], "gltf");
        assert!(!out.exists());
        n += 1;
    }
    assert!(n >= 3, "only {n} hostile glTF files");
}

fn solid_bakes_refuse_open_meshes_and_fill_closed_ones() {
    let torus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/torus.obj");
    let d = tmp();
    let surface = d.path().join("surface.svo");
    let solid = d.path().join("solid.svo");
    ok(&[s(&torus), "--depth", "6", "-o", s(&surface), "-q"]);
    let out = ok(&[s(&torus), "--depth", "6", "--solid", "-o", s(&solid)]);
    assert!(out.contains("interior leaves (closed fill"), "{out}");
    let (a, b) = (read_tree(&surface), read_tree(&solid));
    // Every surface leaf is kept, interior leaves are added, the file round-trips them.
    let interior = b
        .leaves()
        .filter(|l| b.attributes.is_interior(l.index as usize))
        .count();
    assert_eq!(b.leaf_count as usize, a.leaf_count as usize + interior);
    assert!(interior > a.leaf_count as usize);
    for l in a.leaves() {
        let j = b.leaf_at(l.cell).expect("surface leaf kept") as usize;
        assert!(!b.attributes.is_interior(j));
    }
    // The vote mode gives the same file on a closed mesh; binvox holds the solid cells.
    let voted = d.path().join("voted.svo");
    ok(&[
        s(&torus),
        "--depth",
        "6",
        "--solid",
        "vote",
        "-o",
        s(&voted),
        "-q",
    ]);
    assert_eq!(
        std::fs::read(&solid).unwrap(),
        std::fs::read(&voted).unwrap()
    );
    let bv = d.path().join("solid.binvox");
    ok(&[s(&solid), "-o", s(&bv), "-q"]);
    let (_, _, _, got) = svo::io::read_binvox(&std::fs::read(&bv).unwrap()).unwrap();
    assert_eq!(got.len(), b.leaf_count as usize);
    let o = run(&[s(&torus), "--solid", "inside", "-o", s(&voted)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("unknown solid mode `inside` (closed, vote)"),
        "{err}"
    );
    let Some(m) = models() else { return };
    // The bunny has holes in its base.
    let out_path = d.path().join("bunny.svo");
    fails(
        &[
            s(&m.join("stanford/bun_zipper.ply")),
            "--depth",
            "5",
            "--solid",
            "-o",
            s(&out_path),
        ],
        "open edges (edges used by an odd number of triangles), so its inside is not defined: the closed fill needs a closed mesh, the vote fills meshes with holes; --solid needs a closed mesh (use --solid vote for meshes with holes)",
    );
    assert!(!out_path.exists());
    let out = ok(&[
        s(&m.join("stanford/bun_zipper.ply")),
        "--depth",
        "5",
        "--solid",
        "vote",
        "-o",
        s(&out_path),
    ]);
    assert!(out.contains("interior leaves (vote fill"), "{out}");
}

fn scene_files_bake_with_their_defaults_lights_and_views_and_mistakes_are_one_line() {
    let d = tmp();
    let scene = write(
        d.path(),
        "s.toml",
        r#"
        depth = 4
        solid = "closed"
        [[box]]
        min = [0, 0, 0]
        max = [1, 2, 1]
        material = "glass"
        [[sphere]]
        centre = [3, 1, 0.5]
        radius = 0.7
        detail = 6
        material = "water"
        [[light]]
        position = [1, 5, 3]
        intensity = 10
        [[camera]]
        name = "front"
        eye = [1.5, 1, 6]
        target = [1.5, 1, 0.5]
        "#,
    );
    let out = d.path().join("s.svo");
    let text = ok(&[s(&scene), "-o", s(&out)]);
    assert!(text.contains("interior leaves (closed fill"), "{text}");
    let (tree, build) = svo::io::read_file(&out).unwrap();
    assert_eq!(tree.depth, 4);
    assert_eq!(build.scene.lights.len(), 1);
    assert_eq!(build.scene.cameras[0].name, "front");
    assert!(tree.attributes.refractivity.is_per_leaf());
    // The command line wins over the file's defaults.
    ok(&[s(&scene), "--depth", "5", "-o", s(&out), "-q"]);
    let (tree, _) = svo::io::read_file(&out).unwrap();
    assert_eq!(tree.depth, 5);
    assert!(tree.attributes.has_interior());
    // Mistakes: one line naming the file and the entry, no output.
    let bad = d.path().join("bad.svo");
    for (text, needle) in [
        (
            "[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nmaterial = \"glas\"",
            "box 0: unknown material \"glas\"",
        ),
        (
            "[[box]]\nmin = [0, 0, 0]\nmaxi = [1, 1, 1]",
            "unknown field `maxi`",
        ),
        ("[[mesh]]\nfile = \"nowhere.obj\"", "mesh 0"),
        (
            "depth = 99\n[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]",
            "depth 99",
        ),
    ] {
        let f = write(d.path(), "bad.toml", text);
        fails(&[s(&f), "-o", s(&bad)], needle);
        assert!(!bad.exists());
    }
}

/// A scene's relative mesh path is found beside the scene, in a folder of `SVO_MODELS` or in
/// the scene's `models` folders, in that order; found nowhere, one line lists the folders.
fn scene_meshes_are_found_beside_in_svo_models_or_in_models() {
    let d = tmp();
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    for sub in ["scenes", "env/m", "lib/m"] {
        std::fs::create_dir_all(d.path().join(sub)).unwrap();
    }
    write(&d.path().join("env/m"), "tri.obj", tri);
    let scene = write(
        &d.path().join("scenes"),
        "s.toml",
        "depth = 3\nmodels = [\"../lib\"]\n[[mesh]]\nfile = \"m/tri.obj\"\n",
    );
    let out = d.path().join("s.svo");
    let bake = |models: Option<&Path>| {
        let mut c = bin();
        c.args([s(&scene), "-o", s(&out), "-q"]);
        match models {
            Some(m) => c.env("SVO_MODELS", m),
            None => c.env_remove("SVO_MODELS"),
        };
        c.output().unwrap()
    };
    // In SVO_MODELS (a path list: a missing folder first is passed over).
    let list = std::env::join_paths([d.path().join("none"), d.path().join("env")]).unwrap();
    assert!(bake(Some(Path::new(&list))).status.success());
    // Nowhere: one line naming the file and every folder tried, in order.
    std::fs::remove_file(&out).unwrap();
    let o = bake(None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && !out.exists(), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("mesh 0: m/tri.obj is in none of"), "{err}");
    assert!(err.contains("SVO_MODELS"), "{err}");
    let (here, lib) = (err.find("scenes,").unwrap(), err.find("lib").unwrap());
    assert!(here < lib, "{err}");
    // In the scene's `models` folder.
    write(&d.path().join("lib/m"), "tri.obj", tri);
    assert!(bake(None).status.success());
    // Beside the scene first: a broken file there is the one read.
    std::fs::create_dir_all(d.path().join("scenes/m")).unwrap();
    write(&d.path().join("scenes/m"), "tri.obj", "v 0 0 x\n");
    let o = bake(Some(&d.path().join("env")));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("line 1: position parse error"), "{err}");
}

/// The hidden files beside an output: part folders and unfinished outputs.
fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect()
}

/// A bake in parts stopped by SIGINT or SIGTERM at seeded random moments removes its part
/// files and any unfinished output, leaves the previous output as it was and says so in one
/// line; killed (SIGKILL), it leaves its parts, and the next run of the same bake resumes from
/// them to the uninterrupted bake's bytes, removing the parts of a bake with other settings
/// and reporting another output's.
#[cfg(unix)]
fn interrupted_bakes_clean_up_and_killed_ones_resume() {
    use std::time::Instant;
    let d = tmp();
    let torus = svo_tests::repo_root().join("fixtures/torus.obj");
    let (whole, out) = (d.path().join("whole.svo"), d.path().join("out.svo"));
    let args = |o: &Path| -> Vec<String> {
        [
            s(&torus),
            "--depth",
            "10",
            "--memory",
            "16MiB",
            "--threads",
            "1",
            "-o",
            s(o),
        ]
        .map(String::from)
        .to_vec()
    };
    let t = Instant::now();
    let text = ok(&args(&whole).iter().map(String::as_str).collect::<Vec<_>>());
    let full = t.elapsed();
    assert!(text.contains(" parts at level "), "{text}");
    let want = std::fs::read(&whole).unwrap();
    let old = b"the previous output".to_vec();
    let mut next = svo_tests::seeds::xorshift(svo_tests::seeds::seed(0x5167));
    let start = || {
        bin()
            .args(args(&out))
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let signal = |pid: u32, sig: &str| {
        let st = Command::new("kill")
            .args(["-s", sig, &pid.to_string()])
            .status();
        assert!(st.is_ok_and(|s| s.success()), "kill -s {sig}");
    };
    // Waits until the bake has begun its parts (its folder is there), then a seeded random
    // share of the whole bake's time.
    let in_parts = |share: f64| {
        let t = Instant::now();
        while leftovers(d.path())
            .iter()
            .all(|n| !n.starts_with(".svo-parts."))
        {
            assert!(t.elapsed() < full * 20, "no part folder appeared");
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        std::thread::sleep(full.mul_f64(share));
    };
    // Each signal stops at least two runs, at seeded random moments; a run that finished
    // first (the signal came after its output was in place) is not counted.
    for (sig, code) in [("INT", 130), ("TERM", 143)] {
        let mut stopped = 0;
        for attempt in 0..12 {
            if stopped == 2 {
                break;
            }
            std::fs::write(&out, &old).unwrap();
            let child = start();
            in_parts((next() % 1000) as f64 / 1000.0 * 0.6);
            signal(child.id(), sig);
            let o = child.wait_with_output().unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            let now = std::fs::read(&out).unwrap();
            if o.status.success() {
                assert!(now == want, "SIG{sig} attempt {attempt}");
            } else {
                assert_eq!(o.status.code(), Some(code), "SIG{sig}: {err}");
                // One line of error (after the note that the bake goes into parts).
                let errors: Vec<&str> = err.lines().filter(|l| l.contains("error")).collect();
                assert_eq!(errors.len(), 1, "SIG{sig}: {err}");
                assert!(
                    errors[0].starts_with(&format!("svo-bake: error: stopped by SIG{sig}")),
                    "{err}"
                );
                // The previous output, or the whole new one if the signal came as it was
                // renamed into place.
                assert!(now == old || now == want, "SIG{sig} attempt {attempt}");
                stopped += usize::from(now == old);
            }
            assert_eq!(leftovers(d.path()), Vec::<String>::new(), "SIG{sig}");
        }
        assert_eq!(stopped, 2, "SIG{sig} stopped {stopped} of the runs");
    }
    // Killed: the parts stay; the next run takes the finished ones and bakes the rest.
    let mut resumed = 0;
    for round in 0..4 {
        std::fs::remove_file(&out).ok();
        let mut child = start();
        // Late enough that some parts are done, at times into the merge.
        in_parts(0.3 + (next() % 1000) as f64 / 1000.0 * 0.6);
        signal(child.id(), "KILL");
        child.wait().unwrap();
        let text = ok(&args(&out).iter().map(String::as_str).collect::<Vec<_>>());
        resumed += usize::from(text.contains("  resumed "));
        assert!(
            std::fs::read(&out).unwrap() == want,
            "round {round}: {text}"
        );
        assert_eq!(leftovers(d.path()), Vec::<String>::new(), "round {round}");
    }
    assert!(resumed > 0, "no run found parts to resume");
    // Another plan's parts for this output are removed; another output's are reported.
    let stale = d.path().join(".svo-parts.out.svo.0123456789abcdef");
    let other = d.path().join(".svo-parts.other.svo.0123456789abcdef");
    for f in [&stale, &other] {
        std::fs::create_dir_all(f).unwrap();
        std::fs::write(f.join("00000.svopart"), b"junk").unwrap();
    }
    let text = ok(&args(&out).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(
        text.contains(&format!("removed     {}", stale.display())),
        "{text}"
    );
    assert!(
        text.contains(&format!("left alone  {}", other.display())),
        "{text}"
    );
    assert!(!stale.exists() && other.exists());
    assert!(std::fs::read(&out).unwrap() == want);
}

/// `--memory` bakes in parts into the same file as the bake in memory, and says so; plan,
/// part and merge give it too; what no file can hold, a budget that the mesh alone exceeds,
/// a bad size, a solid fill in parts and a part index past the plan are one clear line each.
fn memory_budgets_and_parts_bake_the_same_file_or_refuse_clearly() {
    let d = tmp();
    let torus = svo_tests::repo_root().join("fixtures/torus.obj");
    let whole = d.path().join("whole.svo");
    ok(&[s(&torus), "--depth", "9", "-q", "-o", s(&whole)]);
    let parts = d.path().join("parts.svo");
    let text = ok(&[
        s(&torus),
        "--depth",
        "9",
        "--memory",
        "8MiB",
        "-o",
        s(&parts),
    ]);
    assert!(text.contains(" parts at level "), "{text}");
    assert!(std::fs::read(&whole).unwrap() == std::fs::read(&parts).unwrap());
    // No part files are left beside the output.
    let left: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    let plan = d.path().join("job.svoplan");
    ok(&[
        "plan",
        s(&torus),
        "--depth",
        "9",
        "--parts",
        "3",
        "-o",
        s(&plan),
    ]);
    for i in ["0", "1", "2"] {
        ok(&["part", s(&plan), i, "--threads", "1"]);
    }
    let merged = d.path().join("merged.svo");
    ok(&["merge", s(&plan), "-o", s(&merged)]);
    assert!(std::fs::read(&whole).unwrap() == std::fs::read(&merged).unwrap());
    // Again with each part's triangles in a bin of its own: the same file.
    let text = ok(&[
        "plan",
        s(&torus),
        "--depth",
        "9",
        "--parts",
        "3",
        "--bins",
        "-o",
        s(&plan),
    ]);
    assert!(text.contains("3 bins of the parts' triangles"), "{text}");
    for i in ["0", "1", "2"] {
        ok(&["part", s(&plan), i, "--threads", "1"]);
    }
    std::fs::remove_file(&merged).unwrap();
    ok(&["merge", s(&plan), "-o", s(&merged)]);
    assert!(std::fs::read(&whole).unwrap() == std::fs::read(&merged).unwrap());
    // Merged into format version 3 (chunks at the plan's level): the same tree.
    let chunked = d.path().join("chunked.svo");
    let text = ok(&["merge", s(&plan), "--chunked", "-o", s(&chunked)]);
    assert!(text.contains("(format version 3, "), "{text}");
    let bytes = std::fs::read(&chunked).unwrap();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 3);
    assert_eq!(
        svo::io::from_bytes(&bytes).unwrap().0,
        svo::io::from_bytes(&std::fs::read(&whole).unwrap())
            .unwrap()
            .0
    );
    let bin = d.path().join("job.00001.svobin");
    let mut bytes = std::fs::read(&bin).unwrap();
    bytes.truncate(bytes.len() / 2);
    std::fs::write(&bin, &bytes).unwrap();
    fails(&["part", s(&plan), "1"], "job.00001.svobin: truncated");

    let out = d.path().join("out.svo");
    let o = s(&out);
    fails(
        &[s(&torus), "--depth", "24", "--memory", "8GiB", "-o", o],
        "more than 65536 parts of 2^31 leaves hold",
    );
    fails(
        &[s(&torus), "--depth", "18", "--memory", "8GiB", "-o", o],
        "GB on disk",
    );
    fails(
        &[s(&torus), "--depth", "9", "--memory", "1KiB", "-o", o],
        "raise --memory",
    );
    // Argument errors are clap's: a usage line with them.
    let bad = run(&[s(&torus), "--memory", "lots", "-o", o]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("\"lots\" is not a size"));
    fails(
        &[s(&torus), "--solid", "--memory", "1GiB", "-o", o],
        "solid",
    );
    fails(&["part", s(&plan), "3"], "the plan has 3 parts");
    fails(
        &["merge", s(&d.path().join("none.svoplan")), "-o", o],
        "none.svoplan",
    );
    assert!(!out.exists());
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(
            bakes_bunny_obj_and_ply_and_prints_summary,
            Need::model(BUNNY)
        ),
        trial!(gltf_variants_give_the_same_cells, Need::model(BUNNY)),
        trial!(
            textured_and_transmissive_gltf_get_per_leaf_channels,
            Need::model(BUNNY)
        ),
        trial!(gzipped_dragon_bakes, Need::model(BUNNY)),
        trial!(exports_hold_exactly_the_octree_cells, Need::model(BUNNY)),
        trial!(
            output_is_identical_for_1_2_and_8_threads_and_json_and_quiet_work,
            Need::model(BUNNY)
        ),
        trial!(bad_input_gives_one_clear_line_and_no_output),
        trial!(failed_bake_keeps_the_previous_output),
        trial!(
            killed_bake_leaves_the_old_output_or_the_whole_new_one,
            Need::model(BUNNY)
        ),
        trial!(hostile_gltf_files_give_one_clear_line),
        trial!(solid_bakes_refuse_open_meshes_and_fill_closed_ones),
        trial!(scene_files_bake_with_their_defaults_lights_and_views_and_mistakes_are_one_line),
        trial!(scene_meshes_are_found_beside_in_svo_models_or_in_models),
        trial!(memory_budgets_and_parts_bake_the_same_file_or_refuse_clearly),
        trial!(lod_filtered_writes_version_4_with_the_same_leaves_in_memory_and_in_parts),
        trial!(layout_dag_writes_the_same_tree_and_converts_both_ways),
        trial!(layout_dag_keeps_values_on_a_level),
        #[cfg(unix)]
        trial!(interrupted_bakes_clean_up_and_killed_ones_resume),
    ]
}
