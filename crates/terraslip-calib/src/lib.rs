//! terraslip-calib (to be built).
