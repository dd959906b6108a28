#[path = "../tests/common/mod.rs"]
mod common;
use common::*;
use monohand_core::prelude::*;
fn main() {
    let (cam, right) = stb_rig();
    let mut rng = rng(7);
    let sk = HandSkeleton::default_for(HandSide::Right);
    let mut fitter = HandFitter::new(
        sk,
        FitOptions {
            max_iterations: 500,
            ..Default::default()
        },
    )
    .unwrap();
    for i in 0..15 {
        let truth = random_pose(&sk, &mut rng);
        let joints = forward_kinematics(&sk, &truth);
        let kp = project(&cam, &joints, 0.0, &mut rng).unwrap();
        let kr = project(&right, &joints, 0.0, &mut rng).unwrap();
        let fit = fitter
            .fit(&[View {
                camera: &cam,
                keypoints: &kp,
            }])
            .unwrap();
        let st = fitter
            .fit(&[
                View {
                    camera: &cam,
                    keypoints: &kp,
                },
                View {
                    camera: &right,
                    keypoints: &kr,
                },
            ])
            .unwrap();
        let mut near = truth;
        for a in near.angles.iter_mut() {
            *a += 0.1;
        }
        near.translation.z += 20.0;
        let warm = fitter
            .fit_from(
                &[View {
                    camera: &cam,
                    keypoints: &kp,
                }],
                &near,
            )
            .unwrap();
        let palm: f64 = [0usize, 1, 5, 9, 13, 17]
            .iter()
            .map(|&j| (fit.joints_3d[j] - joints[j]).norm())
            .sum::<f64>()
            / 6.0;
        println!("{i}: scratch err {:.2} palm {:.2} rep {:.2} it {} conv {} | stereo err {:.2} it {} | warm err {:.3} it {} conv {} rep {:.3}",
          mean_error(&fit.joints_3d,&joints), palm, fit.reprojection_error_px, fit.iterations, fit.converged,
          mean_error(&st.joints_3d,&joints), st.iterations,
          mean_error(&warm.joints_3d,&joints), warm.iterations, warm.converged, warm.reprojection_error_px);
    }
}
