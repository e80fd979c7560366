//! Data collection for the disk method (disk paper Sec. III-A): for each orientation a straight
//! TCP move from T-bar to T-tilde with m profiles at even steps, and the chords they show.

use super::{PlanError, Rig, check_reachable, flange_pose};
use crate::calib::disk::{DiskChord, DiskScan};

use crate::rng::gauss;
use nalgebra::{Isometry3, Point3, Rotation3, Unit, UnitQuaternion, Vector2, Vector3};

/// The disk as the simulator knows it (base frame, metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskTarget {
    pub centre: Point3<f64>,
    pub normal: Unit<Vector3<f64>>,
    pub radius: f64,
}

impl DiskTarget {
    /// From a disk specimen's pose (its frame: origin at the centre, z along the normal).
    pub fn from_pose(base_to_specimen: &Isometry3<f64>, radius: f64) -> DiskTarget {
        DiskTarget {
            centre: base_to_specimen * Point3::origin(),
            normal: Unit::new_normalize(base_to_specimen.rotation * Vector3::z()),
            radius,
        }
    }
}

/// How much of the disk a scan sweeps (Fig. 4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Coverage {
    /// From one side across the centre to the other.
    Whole,
    /// From one side up to the centre.
    Half,
}

/// One planned scan: orientation, T-bar, T-tilde and the number of profiles m.
#[derive(Debug, Clone, PartialEq)]
pub struct DiskScanPlan {
    pub r_tcp: Rotation3<f64>,
    pub t_start: Vector3<f64>,
    pub t_end: Vector3<f64>,
    pub m: usize,
}

impl DiskScanPlan {
    /// Fraction along the move of profile j (0-based): (j) / (m - 1).
    pub fn u(&self, j: usize) -> f64 {
        if self.m < 2 {
            0.0
        } else {
            j as f64 / (self.m - 1) as f64
        }
    }

    /// TCP position of profile j.
    pub fn tcp(&self, j: usize) -> Vector3<f64> {
        self.t_start + (self.t_end - self.t_start) * self.u(j)
    }
}

/// What the planner is told for one scan.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanRequest {
    pub r_tcp: Rotation3<f64>,
    /// TCP position near which the laser plane crosses the disk centre (shifted along the move so it
    /// does exactly); None: put the sensor's range centre on the disk centre.
    pub centre_tcp: Option<Vector3<f64>>,
    /// Move direction.
    pub direction: Direction,
}

/// A scan's move direction, given in the base frame or in the sensor frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Direction {
    InBase(Vector3<f64>),
    InSensor(Vector3<f64>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct DiskPlanSpec {
    pub scans: Vec<ScanRequest>,
    pub coverage: Coverage,
    /// Fraction of the disk's extent across the laser plane that the scan spans (0..1): 1 would
    /// start and end exactly at the tangent planes, where chords vanish.
    pub span_fraction: f64,
    /// m, profiles per scan.
    pub m: usize,
    /// Smallest allowed angle between the move and the disk plane or normal (radians, Eq. 2).
    pub min_angle: f64,
}

/// Plan T-bar and T-tilde for every scan, checking Eq. 2 and reachability (IK at every profile).
pub fn plan(
    rig: &Rig,
    disk: &DiskTarget,
    spec: &DiskPlanSpec,
) -> Result<Vec<DiskScanPlan>, PlanError> {
    let plans = plan_unchecked(rig, disk, spec)?;
    for (i, p) in plans.iter().enumerate() {
        for j in 0..p.m {
            check_reachable(&rig.robot, i, &flange_pose(&p.r_tcp, &p.tcp(j)))?;
        }
    }
    Ok(plans)
}

/// The geometry of `plan` without the reachability check (a free-flying sensor).
pub fn plan_unchecked(
    rig: &Rig,
    disk: &DiskTarget,
    spec: &DiskPlanSpec,
) -> Result<Vec<DiskScanPlan>, PlanError> {
    let mut out = Vec::with_capacity(spec.scans.len());
    for (i, req) in spec.scans.iter().enumerate() {
        let r_bs = req.r_tcp * rig.flange_to_sensor.rotation.to_rotation_matrix();
        let y_b = r_bs * Vector3::y();
        let dir = match req.direction {
            Direction::InBase(v) => v,
            Direction::InSensor(v) => r_bs * v,
        };
        if dir.norm() < 1e-12 {
            return Err(PlanError::BadScan {
                scan: i,
                reason: "the scan direction is zero".into(),
            });
        }
        let dir = dir.normalize();
        let n = disk.normal.into_inner();
        let to_plane = dir.dot(&n).abs().clamp(0.0, 1.0).asin();
        if to_plane < spec.min_angle || std::f64::consts::FRAC_PI_2 - to_plane < spec.min_angle {
            return Err(PlanError::BadScan {
                scan: i,
                reason: format!(
                    "the move is {:.2} deg from the disk plane; Eq. 2 wants it neither parallel nor perpendicular to the disk (at least {:.1} deg from both)",
                    to_plane.to_degrees(),
                    spec.min_angle.to_degrees()
                ),
            });
        }
        let sweep = y_b.dot(&dir);
        if sweep.abs() < 1e-3 {
            return Err(PlanError::BadScan {
                scan: i,
                reason: "the move does not sweep the laser plane (it lies in the plane)".into(),
            });
        }
        let half_extent = disk.radius * (1.0 - y_b.dot(&n).powi(2)).max(0.0).sqrt();
        if half_extent < 1e-3 * disk.radius {
            return Err(PlanError::BadScan {
                scan: i,
                reason: "the laser plane is parallel to the disk".into(),
            });
        }
        // The TCP position where the laser plane passes through the disk centre.
        let guess = req.centre_tcp.unwrap_or_else(|| {
            let c = rig.sensor.range_centre().coords;
            disk.centre.coords
                - req.r_tcp
                    * (rig.flange_to_sensor.rotation * c + rig.flange_to_sensor.translation.vector)
        });
        let sensor_origin = guess + req.r_tcp * rig.flange_to_sensor.translation.vector;
        let offset = y_b.dot(&(disk.centre.coords - sensor_origin));
        let t_centre = guess + dir * (offset / sweep);
        // Travel that moves the plane across +-span of the disk's extent.
        let reach = spec.span_fraction * half_extent / sweep.abs();
        let (a, b) = match spec.coverage {
            Coverage::Whole => (-reach, reach),
            Coverage::Half => (-reach, 0.0),
        };
        out.push(DiskScanPlan {
            r_tcp: req.r_tcp,
            t_start: t_centre + dir * a,
            t_end: t_centre + dir * b,
            m: spec.m,
        });
    }
    // R_sensor comes from the moves seen in the sensor frame (Eq. 45): they must not all be parallel.
    let in_sensor: Vec<Vector3<f64>> = out
        .iter()
        .map(|p| {
            (p.r_tcp * rig.flange_to_sensor.rotation.to_rotation_matrix()).inverse()
                * (p.t_end - p.t_start).normalize()
        })
        .collect();
    if let Some(first) = in_sensor.first()
        && in_sensor.iter().all(|d| d.cross(first).norm() < 1e-3)
    {
        return Err(PlanError::BadScan {
            scan: 0,
            reason: "every scan moves in the same direction in the sensor frame, so R_sensor is undetermined (Eq. 45); give directions that differ between scans".into(),
        });
    }
    Ok(out)
}

/// Check that every chord of a plan lies inside the sensor's measurement range and field of view
/// (needed when profiles are ray-cast; the analytic chords of the paper's simulation ignore it).
pub fn check_in_view(
    rig: &Rig,
    disk: &DiskTarget,
    plans: &[DiskScanPlan],
) -> Result<(), PlanError> {
    let s = &rig.sensor;
    for (i, p) in plans.iter().enumerate() {
        for j in 0..p.m {
            let pose = rig.base_to_sensor(&flange_pose(&p.r_tcp, &p.tcp(j)));
            let Some((a, b)) = exact_chord(&pose, disk) else {
                continue;
            };
            for e in [a, b] {
                let q = Point3::new(e.x, 0.0, e.y);
                let depth = s.depth(&q);
                let inside = depth >= s.depth_near
                    && depth <= s.depth_far
                    && s.tan_of(e.x, e.y).abs() <= s.tan_half_fov;
                if !inside {
                    let (zlo, zhi) = s.z_range();
                    return Err(PlanError::BadScan {
                        scan: i,
                        reason: format!(
                            "profile {j}: the chord end ({:.1}, {:.1}) mm is outside the sensor's view (z {:.0}..{:.0} mm, |x| <= {:.0}% of depth); lower span_fraction, use coverage = \"half\", or move more along the sensor's y",
                            e.x * 1e3,
                            e.y * 1e3,
                            zlo * 1e3,
                            zhi * 1e3,
                            s.tan_half_fov * 100.0
                        ),
                    });
                }
            }
        }
    }
    Ok(())
}

/// s_i (Eq. 3): +1 when the move follows the sensor's +y.
pub fn scan_sign(rig: &Rig, p: &DiskScanPlan) -> f64 {
    let y_b = p.r_tcp * (rig.flange_to_sensor.rotation * Vector3::y());
    if y_b.dot(&(p.t_end - p.t_start)) >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// The exact chord where the laser plane (sensor y = 0) cuts the disk, ends ordered by x; None when
/// the plane misses the disk.
pub fn exact_chord(
    base_to_sensor: &Isometry3<f64>,
    disk: &DiskTarget,
) -> Option<(Vector2<f64>, Vector2<f64>)> {
    ChordFrame::of(base_to_sensor, disk)?.chord(base_to_sensor, disk)
}

/// What of `exact_chord` the sensor's orientation alone fixes: the disk's normal in the sensor,
/// the chord's direction and the in-plane direction across it. A scan at one orientation forms
/// it once (the same bits as per profile).
#[derive(Debug, Clone, Copy)]
struct ChordFrame {
    d: Vector3<f64>,
    w: Vector3<f64>,
}

impl ChordFrame {
    /// None where the laser plane is parallel to the disk's.
    fn of(base_to_sensor: &Isometry3<f64>, disk: &DiskTarget) -> Option<ChordFrame> {
        let n = base_to_sensor.inverse_transform_vector(&disk.normal);
        let d = Vector3::y().cross(&n);
        if d.norm() < 1e-12 {
            return None;
        }
        let d = d.normalize();
        let w = n.cross(&d);
        (w.y.abs() >= 1e-15).then_some(ChordFrame { d, w })
    }

    fn chord(
        &self,
        base_to_sensor: &Isometry3<f64>,
        disk: &DiskTarget,
    ) -> Option<(Vector2<f64>, Vector2<f64>)> {
        let (d, w) = (self.d, self.w);
        let q = base_to_sensor.inverse_transform_point(&disk.centre).coords;
        let lambda = -q.y / w.y;
        if lambda.abs() >= disk.radius {
            return None;
        }
        let p0 = q + w * lambda;
        let h = (disk.radius * disk.radius - lambda * lambda).sqrt();
        let (e1, e2) = (p0 - d * h, p0 + d * h);
        let (a, b) = if e1.x <= e2.x { (e1, e2) } else { (e2, e1) };
        Some((Vector2::new(a.x, a.z), Vector2::new(b.x, b.z)))
    }
}

/// What a scan's straight move keeps from profile to profile while the flange's orientation
/// stays the same bit for bit: the sensor's orientation, the mounting's offset turned into the
/// base frame, and the chord frame. The sensor's pose from them is `Rig::base_to_sensor`'s, bit
/// for bit (nalgebra adds the turned offset to the flange's translation the same way).
struct Kept {
    flange: UnitQuaternion<f64>,
    sensor: UnitQuaternion<f64>,
    offset: Vector3<f64>,
    frame: Option<ChordFrame>,
}

/// The sensor's pose at flange pose `f` and its chord frame, through `kept`.
fn sensor_at(
    kept: &mut Option<Kept>,
    rig: &Rig,
    f: &Isometry3<f64>,
    disk: &DiskTarget,
) -> (Isometry3<f64>, Option<ChordFrame>) {
    if let Some(k) = kept
        .as_ref()
        .filter(|k| k.flange.coords == f.rotation.coords)
    {
        let t = f.translation.vector + k.offset;
        return (Isometry3::from_parts(t.into(), k.sensor), k.frame);
    }
    let pose = rig.base_to_sensor(f);
    let frame = ChordFrame::of(&pose, disk);
    *kept = Some(Kept {
        flange: f.rotation,
        sensor: pose.rotation,
        offset: f.rotation * rig.flange_to_sensor.translation.vector,
        frame,
    });
    (pose, frame)
}

/// `exact_chord` on a disk with a form error (`base_to_specimen`: the disk's frame): each end is
/// where the laser plane meets the warped rim, found by Newton's method from the flat rim's end.
pub fn exact_chord_formed(
    base_to_sensor: &Isometry3<f64>,
    disk: &DiskTarget,
    base_to_specimen: &Isometry3<f64>,
    form: &crate::scene::FormError,
) -> Option<(Vector2<f64>, Vector2<f64>)> {
    warped(
        exact_chord(base_to_sensor, disk)?,
        base_to_sensor,
        disk,
        base_to_specimen,
        form,
    )
}

/// The flat rim's chord `(a, b)` moved onto the rim `form` warps.
fn warped(
    (a, b): (Vector2<f64>, Vector2<f64>),
    base_to_sensor: &Isometry3<f64>,
    disk: &DiskTarget,
    base_to_specimen: &Isometry3<f64>,
    form: &crate::scene::FormError,
) -> Option<(Vector2<f64>, Vector2<f64>)> {
    if form.is_none() {
        return Some((a, b));
    }
    let sensor_to_specimen = base_to_sensor.inverse() * base_to_specimen;
    let rim = |t: f64| {
        let p = Point3::new(disk.radius * t.cos(), disk.radius * t.sin(), 0.0);
        sensor_to_specimen * (p + form.displacement(&p))
    };
    let end = |e: Vector2<f64>| {
        let p = sensor_to_specimen.inverse_transform_point(&Point3::new(e.x, 0.0, e.y));
        let q = super::laser_plane_crossing(rim, p.y.atan2(p.x))?;
        Some(Vector2::new(q.x, q.z))
    };
    let (a, b) = (end(a)?, end(b)?);
    Some(if a.x <= b.x { (a, b) } else { (b, a) })
}

/// Analytic chords with Gaussian noise of `sigma` (metres) along each chord (Eq. 52), the disk
/// paper's own simulation. Profiles whose plane misses the disk give no chord.
pub fn analytic_scan(
    rig: &Rig,
    disk: &DiskTarget,
    p: &DiskScanPlan,
    sigma: f64,
    rng: &mut crate::rng::Rng,
) -> DiskScan {
    analytic_scan_with(rig, disk, None, p, sigma, rng, &mut |f, _| *f)
}

/// `analytic_scan` with the robot really at `actual(commanded flange pose, profile index)`, while
/// the chords keep the commanded positions (as a real controller reports them), on a disk with an
/// optional form error (its frame and the error).
pub fn analytic_scan_with(
    rig: &Rig,
    disk: &DiskTarget,
    form: Option<(&Isometry3<f64>, &crate::scene::FormError)>,
    p: &DiskScanPlan,
    sigma: f64,
    rng: &mut crate::rng::Rng,
    actual: &mut dyn FnMut(&Isometry3<f64>, usize) -> Isometry3<f64>,
) -> DiskScan {
    let mut chords = Vec::with_capacity(p.m);
    // `flange_pose`'s rotation, once per scan.
    let r_tcp = UnitQuaternion::from_rotation_matrix(&p.r_tcp);
    let mut kept = None;
    // The poses, then the noises, then the chords: each chord's chain of a division and two
    // square roots then overlaps its neighbours' (no call between them), and each stream is
    // drawn in the same order as before (the robot's pose error has its own).
    let poses: Vec<(Isometry3<f64>, Option<ChordFrame>)> = (0..p.m)
        .map(|j| {
            let flange = Isometry3::from_parts(p.tcp(j).into(), r_tcp);
            sensor_at(&mut kept, rig, &actual(&flange, j), disk)
        })
        .collect();
    // Draw both noises for every profile so streams stay aligned.
    let noise: Vec<(f64, f64)> = (0..p.m)
        .map(|_| (gauss(rng) * sigma, gauss(rng) * sigma))
        .collect();
    // The exact chords, then their noise: each chord's square root and division then overlap
    // the next one's rather than wait behind its geometry.
    let exact: Vec<Option<(Vector2<f64>, Vector2<f64>)>> = poses
        .iter()
        .map(|(pose, frame)| {
            let flat = frame.and_then(|f| f.chord(pose, disk));
            match form {
                Some((frame, f)) => flat.and_then(|c| warped(c, pose, disk, frame, f)),
                None => flat,
            }
        })
        .collect();
    for (j, (chord, &(t1, t2))) in exact.iter().zip(&noise).enumerate() {
        if let Some((a, b)) = chord {
            let len = (b - a).norm();
            if len > 0.0 {
                let dir = (b - a) / len;
                chords.push(DiskChord {
                    u: p.u(j),
                    a: a + dir * t1,
                    b: b + dir * t2,
                });
            }
        }
    }
    DiskScan {
        r_tcp: p.r_tcp,
        t_start: p.t_start,
        t_end: p.t_end,
        s: scan_sign(rig, p),
        chords,
    }
}
