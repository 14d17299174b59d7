//! terraslip-sim (to be built).
