//! terraslip-terrain (to be built).
