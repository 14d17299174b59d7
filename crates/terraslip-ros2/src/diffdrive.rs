//! ICR parameters to diff_drive_controller.
