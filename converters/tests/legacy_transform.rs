//! Transforms compose exactly as the course framework does: within a block M = M · Op in file
//! order (Matrix4f: M = Mat · M, its numbers column by column), nested blocks outer · inner.
//! The imported op lists, applied step by step in listed order, must move points where a direct
//! evaluation of that rule puts them.

use std::path::Path;

use lumo_converters::legacy::{self, ImportOptions};
use lumo_schema::{Object, Scale, TransformOp};
use proptest::prelude::*;

type M = [[f64; 4]; 4];

fn ident() -> M {
    let mut m = [[0.0; 4]; 4];
    for (i, r) in m.iter_mut().enumerate() {
        r[i] = 1.0;
    }
    m
}

fn mul(a: &M, b: &M) -> M {
    let mut m = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                m[i][j] += a[i][k] * b[k][j];
            }
        }
    }
    m
}

/// Rotation about a principal axis by the textbook matrices (right-handed).
fn axis_rot(axis: usize, deg: f64) -> M {
    let (s, c) = deg.to_radians().sin_cos();
    let mut m = ident();
    let (a, b) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    m[a][a] = c;
    m[a][b] = -s;
    m[b][a] = s;
    m[b][b] = c;
    m
}

/// One legacy step as (text, matrix, is Matrix4f).
#[derive(Debug, Clone)]
enum Step {
    Translate([f64; 3]),
    Scale([f64; 3]),
    Uniform(f64),
    Rot(usize, f64),
    Matrix([f64; 16]),
}

impl Step {
    fn text(&self) -> String {
        match self {
            Step::Translate(t) => format!("Translate {} {} {}", t[0], t[1], t[2]),
            Step::Scale(s) => format!("Scale {} {} {}", s[0], s[1], s[2]),
            Step::Uniform(s) => format!("UniformScale {s}"),
            Step::Rot(a, d) => format!("{}Rotate {d}", ["X", "Y", "Z"][*a]),
            Step::Matrix(v) => format!(
                "Matrix4f {{ {} }}",
                v.iter()
                    .map(|x| x.to_string())
                    .collect::<Vec<_>>()
                    .join(" ")
            ),
        }
    }

    fn matrix(&self) -> M {
        let mut m = ident();
        match self {
            Step::Translate(t) => (0..3).for_each(|i| m[i][3] = t[i]),
            Step::Scale(s) => (0..3).for_each(|i| m[i][i] = s[i]),
            Step::Uniform(s) => (0..3).for_each(|i| m[i][i] = *s),
            Step::Rot(a, d) => m = axis_rot(*a, *d),
            // Column by column: the i-th number is row i % 4, column i / 4.
            Step::Matrix(v) => (0..16).for_each(|i| m[i % 4][i / 4] = v[i]),
        }
        m
    }
}

/// The framework's rule for one block.
fn block(steps: &[Step]) -> M {
    steps.iter().fold(ident(), |m, s| match s {
        Step::Matrix(_) => mul(&s.matrix(), &m),
        _ => mul(&m, &s.matrix()),
    })
}

fn apply_m(m: &M, p: [f64; 3]) -> [f64; 3] {
    let mut o = [0.0; 3];
    for (i, v) in o.iter_mut().enumerate() {
        *v = m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3];
    }
    o
}

/// Applies one imported step to a point directly (no matrices for the simple steps).
fn apply_op(op: &TransformOp, p: [f64; 3]) -> [f64; 3] {
    match op {
        TransformOp::Translate(t) => [p[0] + t[0] as f64, p[1] + t[1] as f64, p[2] + t[2] as f64],
        TransformOp::Scale(Scale::Uniform(s)) => p.map(|x| x * *s as f64),
        TransformOp::Scale(Scale::PerAxis(s)) => {
            [p[0] * s[0] as f64, p[1] * s[1] as f64, p[2] * s[2] as f64]
        }
        TransformOp::Rotate(r) => {
            // Rodrigues: p cosθ + (k × p) sinθ + k (k·p)(1 − cosθ).
            let a = r.axis.map(|x| x as f64);
            let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            let k = a.map(|x| x / n);
            let (s, c) = (r.degrees as f64).to_radians().sin_cos();
            let kxp = [
                k[1] * p[2] - k[2] * p[1],
                k[2] * p[0] - k[0] * p[2],
                k[0] * p[1] - k[1] * p[0],
            ];
            let kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
            [0, 1, 2].map(|i| p[i] * c + kxp[i] * s + k[i] * kp * (1.0 - c))
        }
        TransformOp::Matrix(m) => {
            let m: M = m.map(|r| r.map(|x| x as f64));
            apply_m(&m, p)
        }
    }
}

const PTS: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.5], [-0.5, 0.25, 1.5]];

/// Nested blocks (outermost first) around a triangle; returns the imported triangle's op list.
fn import_nested(blocks: &[Vec<Step>]) -> Vec<TransformOp> {
    let mut text = String::from(
        "PerspectiveCamera { center 0 0 50 direction 0 0 -1 up 0 1 0 angle 40 width 8 height 8 }\n\
         Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }\n\
         Group { numObjects 1 MaterialIndex 0\n",
    );
    for (i, b) in blocks.iter().enumerate() {
        // Alternate a Group between transforms: groups must not disturb the composition.
        if i % 2 == 1 {
            text.push_str("Group { numObjects 1\n");
        }
        text.push_str("Transform {\n");
        for s in b {
            text.push_str(&s.text());
            text.push('\n');
        }
    }
    text.push_str(&format!(
        "Triangle {{ vertex0 {} {} {} vertex1 {} {} {} vertex2 {} {} {} }}\n",
        PTS[0][0],
        PTS[0][1],
        PTS[0][2],
        PTS[1][0],
        PTS[1][1],
        PTS[1][2],
        PTS[2][0],
        PTS[2][1],
        PTS[2][2]
    ));
    for i in (0..blocks.len()).rev() {
        text.push_str("}\n");
        if i % 2 == 1 {
            text.push_str("}\n");
        }
    }
    text.push_str("}\n");
    let imported = legacy::import_str(&text, Path::new("t.txt"), &ImportOptions::default())
        .unwrap_or_else(|e| panic!("{e}\n{text}"));
    match &imported.scene.objects[..] {
        [Object::Triangle(t)] => t.transform.clone(),
        other => panic!("{other:?}"),
    }
}

fn check(blocks: &[Vec<Step>]) {
    let ops = import_nested(blocks);
    let m = blocks.iter().fold(ident(), |acc, b| mul(&acc, &block(b)));
    let has_matrix = blocks
        .iter()
        .flatten()
        .any(|s| matches!(s, Step::Matrix(_)));
    if has_matrix {
        assert_eq!(
            ops.len(),
            1,
            "a chain with Matrix4f becomes one matrix: {ops:?}"
        );
    }
    let scale = m.iter().flatten().fold(1.0f64, |a, b| a.max(b.abs()));
    for p in PTS {
        let want = apply_m(&m, p);
        let got = ops.iter().fold(p, |q, op| apply_op(op, q));
        for i in 0..3 {
            // f32 storage of the inputs and of a composed matrix: relative error ~1e-6.
            assert!(
                (want[i] - got[i]).abs() <= 1e-4 * scale,
                "{blocks:?}\nops {ops:?}\npoint {p:?}: want {want:?}, got {got:?}"
            );
        }
    }
}

#[test]
fn spec_examples() {
    // scene04_axes: `Translate 5 0 0  Scale 5 0.2 0.2` scales the cube, then moves it.
    let ops = import_nested(&[vec![
        Step::Translate([5.0, 0.0, 0.0]),
        Step::Scale([5.0, 0.2, 0.2]),
    ]]);
    let p = ops.iter().fold([1.0, 1.0, 1.0], |q, op| apply_op(op, q));
    assert!(
        (p[0] - 10.0).abs() < 1e-6 && (p[1] - 0.2).abs() < 1e-6 && (p[2] - 0.2).abs() < 1e-6,
        "{p:?}"
    );
    // The wine glass: `ZRotate 15  Translate 1.7 0 0` moves, then rotates about the world z axis.
    let ops = import_nested(&[vec![Step::Rot(2, 15.0), Step::Translate([1.7, 0.0, 0.0])]]);
    let p = ops.iter().fold([0.0, 0.0, 0.0], |q, op| apply_op(op, q));
    let (s, c) = 15f64.to_radians().sin_cos();
    assert!(
        (p[0] - 1.7 * c).abs() < 1e-6 && (p[1] - 1.7 * s).abs() < 1e-6,
        "{p:?}"
    );
    // Matrix4f is column by column and left-multiplied: with `UniformScale 2` before it, the
    // object is still scaled first (M = Mat · S), then translated by (1, 2, 3).
    let t = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 2.0, 3.0, 1.0,
    ];
    let ops = import_nested(&[vec![Step::Uniform(2.0), Step::Matrix(t)]]);
    let p = ops.iter().fold([1.0, 1.0, 1.0], |q, op| apply_op(op, q));
    assert_eq!(p, [3.0, 4.0, 5.0]);
}

#[test]
fn nested_transforms_and_groups() {
    check(&[
        vec![
            Step::Translate([4.0, 3.0, 1.0]),
            Step::Rot(0, 10.0),
            Step::Rot(1, 20.0),
        ],
        vec![Step::Rot(2, 30.0), Step::Scale([2.0, 0.5, 3.0])],
        vec![Step::Uniform(0.5), Step::Translate([-1.0, 0.0, 2.0])],
    ]);
    let shear = [
        1.0, 0.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.25, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    check(&[
        vec![
            Step::Translate([1.0, 2.0, 3.0]),
            Step::Matrix(shear),
            Step::Rot(1, 45.0),
        ],
        vec![Step::Scale([1.0, 2.0, 1.0])],
    ]);
}

fn step() -> impl Strategy<Value = Step> {
    let v = || prop::array::uniform3(-5.0f64..5.0).prop_map(|a| a.map(|x| (x * 8.0).round() / 8.0));
    let s = || prop::array::uniform3(0.25f64..3.0).prop_map(|a| a.map(|x| (x * 8.0).round() / 8.0));
    prop_oneof![
        v().prop_map(Step::Translate),
        s().prop_map(Step::Scale),
        (0.25f64..3.0).prop_map(|x| Step::Uniform((x * 8.0).round() / 8.0)),
        (0usize..3, -180.0f64..180.0).prop_map(|(a, d)| Step::Rot(a, d.round())),
        (v(), 0.5f64..2.0).prop_map(|(t, k)| {
            let k = (k * 4.0).round() / 4.0;
            Step::Matrix([
                k, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, t[0], t[1], t[2], 1.0,
            ])
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, failure_persistence: None, ..ProptestConfig::default() })]
    #[test]
    fn random_nested_transforms_compose_exactly(blocks in prop::collection::vec(prop::collection::vec(step(), 1..5), 1..4)) {
        check(&blocks);
    }
}
