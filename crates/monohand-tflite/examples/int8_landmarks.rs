//! Experiment (issue 46): hand_landmark_full with its 1x1 convolutions in int8
//! ([`monohand_tflite::quantize_pointwise`], activation codes from min/max over a few real
//! frames) against the same network in f32, on the dev set's 292 hand crops, by halves.
//!
//! The crops are the dev set's 256x256 images scaled to the network's 224x224 (no rotation
//! to the hand, unlike the pipeline's crops), so the 2D error against the labels is that of
//! this simple crop, the same for both precisions; what matters is the difference.
//!
//! Inputs, made once (RGB bytes, and the labels' joints projected into the 224x224 crops):
//!
//! ```sh
//! D=/work/shared/data; O=/tmp/int8notes/data; mkdir -p $O
//! ffmpeg -i $D/hand_graph_cnn_dev/images/%05d.jpg -vf scale=224:224 -f rawvideo -pix_fmt rgb24 $O/dev224.rgb
//! ffmpeg -i $D/images/pinto/hand.png -vf scale=224:224 -f rawvideo -pix_fmt rgb24 $O/hand224.rgb
//! python3 -c "
//! import json; d=json.load(open('$D/hand_graph_cnn_dev/labels.json')); c=d['camera']
//! out=open('$O/dev224_gt.txt','w')
//! for f in d['frames']:
//!     x,y,w,h=f['crop_box_xywh']; s=256/w; r=224/256
//!     out.write(' '.join('%.4f %.4f'%((c['fx']*s*X/Z+(c['cx']-x)*s)*r,(c['fy']*s*Y/Z+(c['cy']-y)*s)*r)
//!                        for X,Y,Z in f['joints_3d_mm'])+'\n')
//! open('$O/dev_gt3d.txt','w').writelines(' '.join('%.3f'%v for j in f['joints_3d_mm'] for v in j)+'\n'
//!                                        for f in d['frames'])"
//! MONOHAND_OP_THREADS=1 cargo run --release -p monohand-tflite --example int8_landmarks -- \
//!   ~/.cache/monohand/models/hand_landmark_full.tflite $O
//! ```
//!
//! Calibration: `hand224.rgb` and every 18th frame of the first half (8 frames); the
//! second half is never seen by the calibration.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed experiment is a panic

use std::time::Instant;

use monohand_tflite::{int8_input_ranges, quantize_pointwise, PointwiseConv};
use tract_core::internal::*;

const SIDE: usize = 224;
const FRAME: usize = SIDE * SIDE * 3;

/// One crop as the network's input: RGB in [0, 1].
fn input(rgb: &[u8]) -> Tensor {
    let v: Vec<f32> = rgb.iter().map(|&b| b as f32 / 255.0).collect();
    Tensor::from_shape(&[1, SIDE, SIDE, 3], &v).expect("input")
}

type Plan = TypedSimpleState;
/// The keypoints, world landmarks and presence of one frame.
type Output = (Vec<[f32; 2]>, Vec<f32>, f32);
/// Which 1x1 convolutions stay f32.
type Keep<'a> = &'a dyn Fn(&str, &PointwiseConv) -> bool;

/// The 21 keypoints (x, y in crop pixels), the world landmarks (metres) and the presence.
fn run(plan: &mut Plan, x: &Tensor) -> Output {
    let out = plan.run(tvec!(x.clone().into_tvalue())).expect("run");
    let v = |i: usize| -> Vec<f32> {
        let t = out[i].try_as_plain_ram().expect("ram");
        t.as_slice::<f32>().expect("f32").to_vec()
    };
    let kp = v(0);
    let pts = (0..21).map(|j| [kp[3 * j], kp[3 * j + 1]]).collect();
    (pts, v(3), v(1)[0])
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f64 {
    (((a[0] - b[0]) as f64).powi(2) + ((a[1] - b[1]) as f64).powi(2)).sqrt()
}

/// Mean distance (mm) between the world landmarks `p` (metres) and the labels `q` (mm)
/// after the similarity transform that best maps one onto the other (PA-MPJPE): Horn's
/// quaternion method, its largest eigenvector by power iteration.
fn pa_mpjpe(p: &[f32], q: &[[f64; 3]]) -> f64 {
    let p: Vec<[f64; 3]> = p
        .chunks_exact(3)
        .map(|v| [v[0] as f64 * 1e3, v[1] as f64 * 1e3, v[2] as f64 * 1e3])
        .collect();
    let centre = |v: &[[f64; 3]]| -> Vec<[f64; 3]> {
        let n = v.len() as f64;
        let c = v
            .iter()
            .fold([0.0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
        let c = [c[0] / n, c[1] / n, c[2] / n];
        v.iter()
            .map(|b| [b[0] - c[0], b[1] - c[1], b[2] - c[2]])
            .collect()
    };
    let (p, q) = (centre(&p), centre(q));
    let mut s = [[0f64; 3]; 3];
    for (a, b) in p.iter().zip(&q) {
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] += a[i] * b[j];
            }
        }
    }
    let [[xx, xy, xz], [yx, yy, yz], [zx, zy, zz]] = s;
    let n = [
        [xx + yy + zz, yz - zy, zx - xz, xy - yx],
        [yz - zy, xx - yy - zz, xy + yx, zx + xz],
        [zx - xz, xy + yx, -xx + yy - zz, yz + zy],
        [xy - yx, zx + xz, yz + zy, -xx - yy + zz],
    ];
    let shift: f64 = n.iter().flatten().map(|v| v.abs()).sum();
    let mut v = [1.0, 0.3, 0.2, 0.1];
    for _ in 0..2000 {
        let mut w = [0f64; 4];
        for i in 0..4 {
            w[i] = shift * v[i] + (0..4).map(|j| n[i][j] * v[j]).sum::<f64>();
        }
        let len = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        v = w.map(|x| x / len);
    }
    let [w, x, y, z] = v;
    let r = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    let rp: Vec<[f64; 3]> = p
        .iter()
        .map(|a| [0, 1, 2].map(|i| (0..3).map(|j| r[i][j] * a[j]).sum::<f64>()))
        .collect();
    let num: f64 = rp
        .iter()
        .zip(&q)
        .map(|(a, b)| (0..3).map(|i| a[i] * b[i]).sum::<f64>())
        .sum();
    let den: f64 = p.iter().map(|a| a.iter().map(|v| v * v).sum::<f64>()).sum();
    let scale = num / den;
    rp.iter()
        .zip(&q)
        .map(|(a, b)| {
            (0..3)
                .map(|i| (scale * a[i] - b[i]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .sum::<f64>()
        / q.len() as f64
}

fn time(plan: &mut Plan, x: &Tensor) -> f64 {
    let mut best = f64::MAX;
    for _ in 0..3 {
        let t = Instant::now();
        for _ in 0..20 {
            plan.run(tvec!(x.clone().into_tvalue())).expect("run");
        }
        best = best.min(t.elapsed().as_secs_f64() / 20.0);
    }
    best
}

/// The ground truth of the dev frames: each frame's 21 keypoints in the 224-px crop, and its
/// 21 joints in 3D.
#[allow(clippy::type_complexity)]
fn labels(dir: &str) -> TractResult<(Vec<Vec<[f32; 2]>>, Vec<Vec<[f64; 3]>>)> {
    let gt: Vec<Vec<[f32; 2]>> = std::fs::read_to_string(format!("{dir}/dev224_gt.txt"))?
        .lines()
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            v.chunks_exact(2).map(|p| [p[0], p[1]]).collect()
        })
        .collect();
    let gt3: Vec<Vec<[f64; 3]>> = std::fs::read_to_string(format!("{dir}/dev_gt3d.txt"))?
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            v.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect()
        })
        .collect();
    Ok((gt, gt3))
}

/// The mean 2D error of `outs` against the labels `gt` over the frames `r`, px.
fn err_2d(outs: &[Output], gt: &[Vec<[f32; 2]>], r: std::ops::Range<usize>) -> f64 {
    let n = r.len() as f64;
    r.map(|i| {
        outs[i]
            .0
            .iter()
            .zip(&gt[i])
            .map(|(a, b)| dist(*a, *b))
            .sum::<f64>()
            / 21.0
    })
    .sum::<f64>()
        / n
}

/// The mean PA-MPJPE of the world landmarks of `outs` against `gt3` over the frames `r`, mm.
fn err_pa(outs: &[Output], gt3: &[Vec<[f64; 3]>], r: std::ops::Range<usize>) -> f64 {
    let n = r.len() as f64;
    r.map(|i| pa_mpjpe(&outs[i].1, &gt3[i])).sum::<f64>() / n
}

/// One half `h` (frames `r`) of an int8 variant's outputs `outs` against f32's.
fn report_half(
    h: usize,
    outs: &[Output],
    f32_out: &[Output],
    r: std::ops::Range<usize>,
    err: &dyn Fn(&[Output], std::ops::Range<usize>) -> f64,
    pa: &dyn Fn(&[Output], std::ops::Range<usize>) -> f64,
) {
    let (e32, e8) = (err(f32_out, r.clone()), err(outs, r.clone()));
    let mut diff = Vec::new();
    let (mut world, mut presence) = (0f64, 0f64);
    for i in r.clone() {
        for (a, b) in outs[i].0.iter().zip(&f32_out[i].0) {
            diff.push(dist(*a, *b));
        }
        let w: f64 = outs[i]
            .1
            .chunks_exact(3)
            .zip(f32_out[i].1.chunks_exact(3))
            .map(|(a, b)| {
                a.iter()
                    .zip(b)
                    .map(|(a, b)| ((a - b) as f64).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .sum::<f64>()
            / 21.0;
        world += w * 1e3 / r.len() as f64;
        presence = presence.max((outs[i].2 - f32_out[i].2).abs() as f64);
    }
    println!(
        "  half {h}: world landmarks' PA-MPJPE {:.3} mm against f32's {:.3} ({:+.3} mm)",
        pa(outs, r.clone()),
        pa(f32_out, r.clone()),
        pa(outs, r.clone()) - pa(f32_out, r.clone())
    );
    diff.sort_by(|a, b| a.total_cmp(b));
    let mean = diff.iter().sum::<f64>() / diff.len() as f64;
    println!(
        "  half {h}: 2D error {e8:.3} px against f32's {e32:.3} ({:+.2} %); int8 - f32 \
         keypoints: mean {mean:.3} px, p95 {:.3}, max {:.3}; world landmarks {world:.2} mm \
         apart (mean); presence logit max |diff| {presence:.3}",
        100.0 * (e8 / e32 - 1.0),
        diff[diff.len() * 95 / 100],
        diff[diff.len() - 1]
    );
}

fn main() -> TractResult<()> {
    let model_path = std::env::args().nth(1).context("model path")?;
    let dir = std::env::args().nth(2).context("data directory")?;
    let bytes = std::fs::read(&model_path)?;
    let dev = std::fs::read(format!("{dir}/dev224.rgb"))?;
    let hand = std::fs::read(format!("{dir}/hand224.rgb"))?;
    let (gt, gt3) = labels(&dir)?;
    let frames: Vec<Tensor> = dev.chunks_exact(FRAME).map(input).collect();
    assert_eq!(frames.len(), gt.len());
    let half = frames.len() / 2;

    let model = monohand_tflite::import(&bytes).map_err(|e| format_err!("{e}"))?;
    let mut calib: Vec<TVec<Tensor>> = vec![tvec!(input(&hand))];
    calib.extend((0..half).step_by(18).map(|i| tvec!(frames[i].clone())));
    let ranges = int8_input_ranges(&model, &calib)?;
    let mut names: Vec<_> = ranges.iter().collect();
    names.sort_by(|a, b| a.0.cmp(b.0));
    for (name, r) in &names {
        let q = r.quant();
        println!(
            "  {name}: [{:.3}, {:.3}] step {:.4} zero {}",
            r.min,
            r.max,
            q.scale(),
            q.zero_point()
        );
    }

    let f32_plan = model.clone().into_optimized()?.into_runnable()?.spawn()?;
    let variants: [(&str, Keep); 2] = [
        ("int8, all 30 1x1", &|_, _| false),
        (
            "int8, the two 112x112 1x1 kept f32",
            &|_, op: &PointwiseConv| op.input_channels() <= 24 && op.output_channels() <= 64,
        ),
    ];
    let mut plans = vec![("f32".to_string(), f32_plan, 0usize)];
    for (label, keep) in variants {
        let mut m = model.clone();
        let n = quantize_pointwise(&mut m, &ranges, keep)?;
        plans.push((
            label.to_string(),
            m.into_optimized()?.into_runnable()?.spawn()?,
            n,
        ));
    }
    // Times interleaved (7 rounds, each plan in turn), the median round per plan.
    let mut times = vec![Vec::new(); plans.len()];
    for _ in 0..7 {
        for (p, t) in plans.iter_mut().zip(&mut times) {
            t.push(time(&mut p.1, &frames[0]));
        }
    }
    let median = |t: &mut Vec<f64>| {
        t.sort_by(|a, b| a.total_cmp(b));
        t[t.len() / 2]
    };
    let times: Vec<f64> = times.iter_mut().map(median).collect();
    let outs: Vec<Vec<_>> = plans
        .iter_mut()
        .map(|p| frames.iter().map(|x| run(&mut p.1, x)).collect())
        .collect();
    let err = |outs: &[Output], r: std::ops::Range<usize>| err_2d(outs, &gt, r);
    let pa = |outs: &[Output], r: std::ops::Range<usize>| err_pa(outs, &gt3, r);
    let halves = [0..half, half..frames.len()];
    let f32_out = &outs[0];
    println!(
        "f32: {:.2} ms per run (one image, median of 7 interleaved rounds of best-of-3x20)",
        times[0] * 1e3
    );
    for (h, r) in halves.iter().enumerate() {
        println!(
            "  half {h}: 2D error against the labels {:.3} px (224-px crop), world landmarks' \
             PA-MPJPE {:.3} mm",
            err(f32_out, r.clone()),
            pa(f32_out, r.clone())
        );
    }
    for ((label, _, n), (outs, t8)) in plans.iter().zip(outs.iter().zip(&times)).skip(1) {
        println!(
            "{label} ({n} layers): {:.2} ms per run ({:.2}x f32's speed)",
            t8 * 1e3,
            times[0] / t8
        );
        for (h, r) in halves.iter().enumerate() {
            report_half(h, outs, f32_out, r.clone(), &err, &pa);
        }
    }
    Ok(())
}
