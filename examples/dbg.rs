use lasercal::features::{self, SplitMerge};
use lasercal::scene::{Scene, Specimen, SpecimenKind, Table};
use lasercal::sensor::SensorModel;
use lasercal::testkit;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::RngExt;
fn main() {
    let sensor = SensorModel::gocator_2340().ideal();
    let mut g = testkit::rng(32);
    let cfg = SplitMerge::default();
    for i in 0..100 {
        let tilt = g.random_range(0.0..0.6);
        let axis = nalgebra::Unit::new_normalize(Vector3::new(
            g.random_range(-1.0..1.0),
            g.random_range(-1.0..1.0),
            0.0,
        ));
        let disk_pose = Isometry3::from_parts(
            Translation3::new(
                g.random_range(-0.01..0.01),
                g.random_range(-0.04..0.04),
                g.random_range(-0.03..0.03),
            ),
            UnitQuaternion::from_axis_angle(&axis, tilt),
        );
        let mut scene = Scene::new(Some(Table {
            height_m: -0.09,
            reflectance: 0.3,
        }));
        scene.add(
            &Specimen::new(SpecimenKind::DiskOnCylinder {
                radius: 0.05,
                height: 0.02,
            }),
            disk_pose,
        );
        let pose = Isometry3::identity();
        let profile = sensor.profile(&scene, &pose, None);
        let target = lasercal::sim::disk::DiskTarget::from_pose(&disk_pose, 0.05);
        let Some((a, b)) = lasercal::sim::disk::exact_chord(&pose, &target) else {
            continue;
        };
        let Ok(ch) = features::disk_chord_step(&profile, &sensor, 0.05, &cfg) else {
            continue;
        };
        for (got, want) in [(ch.a, a), (ch.b, b)] {
            let step = sensor.x_step_at_depth(sensor.depth(&Point3::new(want.x, 0.0, want.y)));
            if (got.x - want.x).abs() > step {
                println!(
                    "case {i}: got {:?} want {:?} step {:.4}",
                    got * 1e3,
                    want * 1e3,
                    step * 1e3
                );
                let tw = sensor.tan_of(want.x, want.y);
                for k in 0..sensor.columns {
                    let t = sensor.column_tan(k);
                    if (t - tw).abs() < 4.0 * 2.0 * sensor.tan_half_fov / 1279.0 {
                        println!(
                            "  col {k} tan {t:.6} (want {tw:.6}) point {:?}",
                            profile.points[k].map(|p| (p.x * 1e3, p.z * 1e3))
                        );
                    }
                }
                return;
            }
        }
    }
}
