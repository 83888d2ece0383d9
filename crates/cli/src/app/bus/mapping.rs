//! How the arm's servos are addressed and how a joint's angle is a tick of its servo's
//! position register.

/// The servos' addresses and register mapping, checked (built from a setup's `[servo_bus]`
/// table by `ServoBus::of`, in `app/setup/servos.rs`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoBus {
    pub ids: [u8; 4],
    pub directions: [f64; 4],
    pub zero_ticks: [f64; 4],
    /// Counts per output revolution of each joint's servo (a stepper's microsteps).
    pub counts_per_revolution: [f64; 4],
    /// The bus's protocol (`None`: the servos speak neither, e.g. a hobby PWM servo or a
    /// stepper; the goals are then only exported).
    pub protocol: Option<super::Protocol>,
    pub gripper: Option<super::driver::GripperServo>,
}

impl ServoBus {
    /// Joint `j`'s goal `q` (rad, the setup's sense) in ticks of its servo's position register.
    pub fn ticks(&self, j: usize, q: f64) -> f64 {
        let count = std::f64::consts::TAU / self.counts_per_revolution[j];
        self.zero_ticks[j] + self.directions[j] * (q / count).round()
    }

    /// Joint `j`'s angle (rad, the setup's sense) at tick `tick` of its servo's register
    /// ([`ServoBus::ticks`]' inverse on whole ticks).
    pub fn angle(&self, j: usize, tick: f64) -> f64 {
        let count = std::f64::consts::TAU / self.counts_per_revolution[j];
        self.directions[j] * (tick - self.zero_ticks[j]) * count
    }
}
