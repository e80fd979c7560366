//! Rays and profiles per second for each specimen (issue 3 target: >= 20 M rays/s/core on the
//! disk scene).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use lasercal::scene::{Scene, Specimen, SpecimenKind, Table};
use lasercal::sensor::SensorModel;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use std::hint::black_box;

fn scenes() -> Vec<(&'static str, Scene)> {
    let kinds = [
        (
            "disk-cylinder",
            SpecimenKind::DiskOnCylinder {
                radius: 0.05,
                height: 0.02,
            },
        ),
        (
            "disk-paper",
            SpecimenKind::DiskOnPaper {
                radius: 0.05,
                paper_half: 0.15,
            },
        ),
        (
            "ball",
            SpecimenKind::BallOnPost {
                radius: 0.0695,
                post_radius: 0.01,
                post_height: 0.08,
            },
        ),
        (
            "parallel-bar",
            SpecimenKind::ParallelBar {
                length: 0.15,
                width: 0.025,
                height: 0.012,
            },
        ),
        (
            "knife-blade",
            SpecimenKind::KnifeBlade {
                length: 0.06,
                width: 0.018,
                thickness: 0.0006,
                bevel: 0.001,
            },
        ),
    ];
    kinds
        .into_iter()
        .map(|(name, k)| {
            let mut s = Scene::new(Some(Table {
                height_m: -0.08,
                reflectance: 0.3,
            }));
            s.add(
                &Specimen::new(k),
                Isometry3::from_parts(
                    Translation3::new(0.005, 0.01, -0.02),
                    UnitQuaternion::from_euler_angles(0.2, -0.1, 0.3),
                ),
            );
            (name, s)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let sensor = SensorModel::gocator_2340();
    let pose = Isometry3::identity();
    let apex = pose * sensor.apex();
    let dirs: Vec<Vector3<f64>> = (0..sensor.columns)
        .map(|k| pose.rotation * sensor.column_dir(k))
        .collect();
    for (name, scene) in scenes() {
        let mut g = c.benchmark_group(format!("raycast/{name}"));
        g.throughput(Throughput::Elements(dirs.len() as u64));
        g.bench_function("rays", |b| {
            b.iter(|| {
                let mut n = 0usize;
                for d in &dirs {
                    n += scene.cast_ray(black_box(&apex), d, 1.0).is_some() as usize;
                }
                black_box(n)
            })
        });
        g.throughput(Throughput::Elements(1));
        g.bench_function("profile", |b| {
            b.iter(|| black_box(sensor.profile(&scene, black_box(&pose), None)))
        });
        g.finish();
    }
    let _ = Point3::<f64>::origin();
}

criterion_group!(benches, bench);
criterion_main!(benches);
