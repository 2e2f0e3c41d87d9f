//! Non-physical parameters are rejected at construction with an error naming the parameter and its range.
use millcomp_sim::SimError;
use millcomp_sim::force::{BallEndForceModel, CutConditions};
use millcomp_sim::groove::{DepthProfile, GrooveConfig, GrooveStage};
use millcomp_sim::spindle::PztSpindle;
use millcomp_sim::stiffness::{MachineStiffness, TiltedToolStiffness};
use millcomp_sim::thinwall::ThinWallConfig;
use millcomp_sim::tool::BallEndTool;

fn name_of(e: SimError) -> (&'static str, String) {
    match e {
        SimError::InvalidParameter { name, allowed, .. } => (name, allowed.to_string()),
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

#[test]
fn negative_stiffness() {
    let (n, a) = name_of(TiltedToolStiffness::new(1.22, -0.114).unwrap_err());
    assert_eq!(n, "radial_n_per_um");
    assert!(a.contains("> 0"));
    let mut cfg = GrooveConfig::thesis(20.0, 8.0).unwrap();
    cfg.stiffness.axial_n_per_um = 0.0;
    assert_eq!(name_of(cfg.validate().unwrap_err()).0, "axial_n_per_um");
    assert_eq!(
        name_of(MachineStiffness::new(-1.0, 0.0).unwrap_err()).0,
        "mean_n_per_um"
    );
}

#[test]
fn depth_beyond_ball_radius() {
    let m = BallEndForceModel::default();
    let c = CutConditions::new(401.0, 10.0, 10_000.0, 20.0).unwrap();
    let (n, a) = name_of(m.check_conditions(&c).unwrap_err());
    assert_eq!(n, "depth_um");
    assert!(a.contains("radius"));
    assert!(m.revolution(&c, 36).is_err());
    let mut cfg = GrooveConfig::thesis(20.0, 8.0).unwrap();
    cfg.program.depth_profile = DepthProfile::Ramp {
        from_um: 0.0,
        to_um: 450.0,
    };
    assert_eq!(name_of(cfg.validate().unwrap_err()).0, "depth_um");
    assert!(GrooveStage::new(cfg, 5e-5).is_err());
}

#[test]
fn tilt_of_90_degrees_or_more() {
    let (n, a) = name_of(CutConditions::new(50.0, 10.0, 10_000.0, 90.0).unwrap_err());
    assert_eq!(n, "tilt_deg");
    assert!(a.contains("< 90"));
    assert_eq!(
        name_of(GrooveConfig::thesis(95.0, 8.0).unwrap_err()).0,
        "tilt_deg"
    );
    assert_eq!(
        name_of(
            TiltedToolStiffness::default()
                .z_stiffness_n_per_um(90.0)
                .unwrap_err()
        )
        .0,
        "tilt_deg"
    );
}

#[test]
fn zero_speed_and_zero_feed() {
    assert_eq!(
        name_of(CutConditions::new(50.0, 10.0, 0.0, 20.0).unwrap_err()).0,
        "speed_rpm"
    );
    assert_eq!(
        name_of(CutConditions::new(50.0, 0.0, 10_000.0, 20.0).unwrap_err()).0,
        "upfeed_um"
    );
    let mut cfg = GrooveConfig::thesis(20.0, 8.0).unwrap();
    cfg.program.speed_rpm = 0.0;
    assert_eq!(name_of(cfg.validate().unwrap_err()).0, "speed_rpm");
    let mut tw = ThinWallConfig::paper(100.0).unwrap();
    tw.speed_rpm = 0.0;
    assert_eq!(name_of(tw.validate().unwrap_err()).0, "speed_rpm");
}

#[test]
fn other_nonphysical_values() {
    assert_eq!(
        name_of(BallEndTool::new(400.0, -1.0, 10.0).unwrap_err()).0,
        "wearland_um"
    );
    assert_eq!(
        name_of(BallEndTool::new(400.0, 5.0, f64::NAN).unwrap_err()).0,
        "runout_um"
    );
    assert_eq!(
        name_of(PztSpindle::new(0.05, 0.46, 1302.0, None, Some(-1e-3)).unwrap_err()).0,
        "dead_time_s"
    );
    assert_eq!(
        name_of(PztSpindle::default().discretize(0.0).unwrap_err()).0,
        "dt_s"
    );
    let mut tw = ThinWallConfig::paper(100.0).unwrap();
    tw.tool_stiffness_n_per_um = -1.0;
    assert_eq!(
        name_of(tw.validate().unwrap_err()).0,
        "tool_stiffness_n_per_um"
    );
    // NaN never reaches the actuator: a NaN command holds the last applied voltage
    let mut st = GrooveStage::new(GrooveConfig::thesis(20.0, 8.0).unwrap(), 5e-5).unwrap();
    st.step(100.0);
    assert_eq!(st.step(f64::NAN).applied_v, 100.0);
}
