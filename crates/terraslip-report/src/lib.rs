//! terraslip-report (to be built).
