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
#![cfg_attr(not(feature = "std"), no_std)]
#![allow(non_snake_case)]

pub mod angle;
pub mod filter;
pub mod kinematics;
pub mod model;
pub mod odometry;
pub mod rng;
pub mod schedule;
pub mod terrain_belief;

pub use filter::{Filter, FilterConfig, FilterError, IcrBand, IcrNoise, PoseFix, Variant};
pub use kinematics::{IcrParams, KinematicsError, Twist};
pub use odometry::Odometry;
pub use schedule::{ChangeAction, IcrStd, NoiseSchedule, ScheduleConfig};
