//! terraslip-core: the estimator that runs on the robot.
//!
//! `no_std`, no allocation: fixed-size `nalgebra` matrices only. Frames follow
//! ROS REP-103 (body x forward, y left; world ENU, yaw counter-clockwise from
//! east). All quantities are SI.
//!
//! The kinematic model is the ICR (instantaneous centre of rotation) model of
//! skid steering: the left tread, the right tread and the body each have an
//! ICR on a common line parallel to the body x axis, at lateral offsets `y_l`,
//! `y_r` and longitudinal offset `x_c`. See [`kinematics`].
//!
//! * [`kinematics`]: the ICR model, tread speeds to body twist and back.
//! * [`compensate`]: the command a drive controller must get for a desired twist.
//! * [`slip`]: the coordinates a filter carries the slip parameters in.
//! * [`model`]: the filter's state and process model.
//! * [`odometry`]: the covariance of the model's body twist.
//! * [`twist_noise`]: the twist error learned at the published horizon.
//! * [`filter`]: the EKF (predict, update, gates, noise learning, resets).
//! * [`gated_fix`]: what a fix the gate rejects says about the stated pose.
//! * [`schedule`]: what terrain evidence does to the filter.
//! * [`estimator`]: filter + schedule + stream timing: the online API.
//! * [`terrain_belief`]: the terrain HMM and vote over classifier outputs.
#![cfg_attr(not(feature = "std"), no_std)]
#![allow(non_snake_case)]
// `!(x > 0.0)` is meant: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod angle;
pub mod compensate;
pub mod estimator;
pub mod filter;
pub mod gated_fix;
pub mod icr_model;
pub mod kinematics;
pub mod model;
pub mod odometry;
pub mod outage_growth;
pub mod outage_noise;
pub mod rng;
pub mod schedule;
pub mod slip;
pub mod terrain_belief;
pub mod twist_noise;

pub use estimator::Estimator;
pub use filter::{
    Filter, FilterConfig, FilterError, IcrBand, MeasurementConfig, PoseFix, Prior, SlipStd, Variant,
};
pub use kinematics::{IcrParams, KinematicsError, Twist};
pub use schedule::{ChangeAction, NoiseSchedule, ScheduleConfig};
pub use slip::{Chart, TreadInput};
