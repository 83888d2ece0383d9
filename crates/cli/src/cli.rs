//! The command line.

use crate::app::setup::conditions::{ConditionOptions, EstimatorChoice};
use crate::app::studies::simulate::ControllerName;
use crate::args;
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// chessarm: from a chess move to the joint torques of a 4-DOF arm, verified in simulation.
///
/// All values are SI (m, rad, s, kg, N·m) unless a flag says otherwise. With no command,
/// runs `demo`.
#[derive(Debug, Parser)]
#[command(name = "chessarm", version, about, long_about = None)]
pub struct Cli {
    /// Setup file (TOML) describing the arm and the board; `chessarm arm` prints the default.
    #[arg(long, global = true, value_name = "FILE")]
    pub arm: Option<PathBuf>,
    /// The arm from a URDF file instead: a base yaw and three parallel pitch joints on the way
    /// from the root link to the tool link; grippers and other branches are held and their mass
    /// carried. Angles are the file's, positions in its root link's frame; the board and the
    /// rest come from --arm or the defaults.
    #[arg(long, global = true, value_name = "FILE")]
    pub urdf: Option<PathBuf>,
    /// With --urdf: hold these joints at these values (rad, m for a prismatic joint), e.g.
    /// `--lock wrist_roll=0`; a joint's <mimic> followers follow.
    #[arg(long, global = true, value_name = "JOINT=VALUE,…", value_parser = args::locks, requires = "urdf")]
    pub lock: Option<args::Locks>,
    /// With --urdf: the link at the tool tip (default: a link named like tool, tcp, ee or
    /// end_effector at the end of a fixed joint, or the only such link).
    #[arg(long, global = true, value_name = "LINK", requires = "urdf")]
    pub tool: Option<String>,
    /// With --urdf: the tool point in the tool link's frame, m (default 0,0,0).
    #[arg(long, global = true, value_name = "X,Y,Z", value_parser = args::three, requires = "urdf", allow_hyphen_values = true)]
    pub tool_offset: Option<[f64; 3]>,
    /// What drives the joints, over the setup's: `torque` (torque motors, the default), a
    /// built-in servo (sts3215, sts3215-12v, xl430, xm430, mg996r), the geared stepper nema17,
    /// or an `[actuators.NAME]` of the setup; one name for every joint or four, base to tool.
    #[arg(long, global = true, value_name = "NAME[,NAME,NAME,NAME]", value_delimiter = ',')]
    pub actuator: Option<Vec<String>>,
    /// With servos or steppers: how the host computes the goal positions it sends — `plain` (the planned
    /// angles), `sag` (offset to hold them against gravity), `feedforward` (offset by the plan's
    /// inverse dynamics); `simulate` compares several given with commas.
    #[arg(long, global = true, value_name = "plain|sag|feedforward[,…]", value_delimiter = ',', value_parser = args::servo_command)]
    pub servo_command: Option<Vec<chessarm_core::control::servo_host::ServoCommand>>,
    /// With servos or steppers: how often the host sends goal positions, Hz (default 100;
    /// 10 to 10 000).
    #[arg(long, global = true, value_name = "HZ", value_parser = args::bus_rate)]
    pub bus_rate: Option<f64>,
    /// Print the result as one line of JSON on standard output (for scripts) instead of a
    /// summary for people; tables and progress then go to standard error.
    #[arg(long, global = true)]
    pub json: bool,
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// The shard from a batch scheduler's environment instead of `--shard`.
#[derive(Debug, Clone, Default, Args)]
pub struct BatchArgs {
    /// Take the shard from a batch array job: Slurm's SLURM_ARRAY_TASK_ID (counted from
    /// SLURM_ARRAY_TASK_MIN, default 0) of SLURM_ARRAY_TASK_COUNT, or Kubernetes' 0-based
    /// JOB_COMPLETION_INDEX of --shards N.
    #[arg(long)]
    pub shard_from_env: bool,
    /// The number of shards with --shard-from-env under Kubernetes (its Job's completions).
    #[arg(long, value_name = "N")]
    pub shards: Option<usize>,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print the arm and board setup as TOML (the report's arm unless --arm is given).
    Arm,
    /// Forward kinematics: tool tip, pitch and every DH frame for joint angles (rad), as JSON.
    Fk(FkArgs),
    /// Inverse kinematics (elbow up, tool down unless --pitch): joint angles for a tip position.
    Ik(IkArgs),
    /// Print the arm as URDF (links with mass, COM and inertia; joints with limits; a tool frame).
    Urdf,
    /// Whether the arm serves the board (every square and slot at every grip height, every
    /// traverse, holding the heaviest piece); with --fit, the largest board it serves and its
    /// pose, printed as a setup file (pieces scaled with the squares).
    Board(BoardArgs),
    /// Plan a scenario (Cartesian LSPB path → IK → joint trajectory) or chess moves (--moves,
    /// time-optimal with a phase-plane plot); CSV, plots, optional XLSX.
    Plan(PlanArgs),
    /// Dynamics terms at a state: M(q), C(q, q̇)·q̇ and g(q), as JSON.
    Dynamics(DynamicsArgs),
    /// Closed-loop simulation of a scenario with computed-torque PD and/or PID control.
    Simulate(SimulateArgs),
    /// The report's study end to end (plan, PD and PID simulations, plots, summary) into out/.
    Demo(DemoArgs),
    /// Gains from response specs (settling time and overshoot, or ωn and ζ), verified by simulation.
    Gains(GainsArgs),
    /// Sweep gain combinations in parallel; CSV of every candidate, heat map, best picks.
    Tune(TuneArgs),
    /// Play chess with the simulated arm: a PGN game, a move list, or against an engine.
    Play(PlayArgs),
    /// Where the board lies (and the joints' zero errors) from the arm touching square centres:
    /// angles typed (--touch) or read over the servos' bus (--port); a fitted setup file, the
    /// residual per touch printed and plotted.
    Calibrate(CalibrateArgs),
    /// A simulated servo bus on a pseudo-terminal (for `play --port` without hardware, and
    /// the vendors' SDKs): the setup's servos answering their protocol, the arm's dynamics
    /// behind them. Prints the device's path, then serves until Ctrl-C; `pose Q1,Q2,Q3,Q4`
    /// lines on its standard input move the arm by hand while its torque is off.
    BusSim(BusSimArgs),
    /// Monte Carlo: randomised trials (sensor noise, model errors, piece masses) of each
    /// controller; success rate and placement-error distribution.
    Robustness(RobustnessArgs),
}

#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// A touch: the square whose centre the tool tip touched and the joint angles then, rad
    /// (the setup's sense), e.g. `--touch a1=0.62,1.2,-1.9,-0.87`; repeat for each (at least 3; 4
    /// with --zeros, at different distances from the base).
    #[arg(long = "touch", value_name = "SQUARE=Q1,Q2,Q3,Q4", allow_hyphen_values = true)]
    pub touches: Vec<String>,
    /// Read the angles from the servos on this serial device instead: their torque goes off,
    /// and for each of --squares you move the tool tip onto its centre and press Enter.
    #[arg(long, value_name = "DEVICE")]
    pub port: Option<PathBuf>,
    /// With --port: the squares to touch, in order.
    #[arg(long, value_delimiter = ',', default_value = "a1,h1,h8,a8")]
    pub squares: Vec<String>,
    /// Fit the zero errors of joints 2–4 too (written as `[servo_bus] zero_ticks` with servos).
    #[arg(long)]
    pub zeros: bool,
    /// With --port: how long a servo may take to answer, ms.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub reply_timeout_ms: u64,
    /// Refuse the calibration when a touch is further than this from where the fitted board
    /// puts its square's centre, mm (default: half the 5 mm placement tolerance; honest touches
    /// fit within about 1 mm).
    #[arg(
        long,
        default_value_t = chessarm_core::arm::calibration::MAX_RESIDUAL * 1e3,
        value_parser = args::residual_mm,
        allow_hyphen_values = true
    )]
    pub max_residual_mm: f64,
    /// Output folder: setup.toml (the setup with the fitted board), residuals.png,
    /// calibration.json (and bus.jsonl with --port).
    #[arg(long, default_value = "out/calibrate")]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub struct BusSimArgs {
    /// The protocol (default: the setup's servos', or `[servo_bus] protocol`).
    #[arg(long, value_enum)]
    pub protocol: Option<crate::app::bus::Protocol>,
    /// Log every instruction received to this file, one JSON line each (`t` s, `packet` hex).
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Servo ID@N stops answering from the N-th goal packet on (a lost reply).
    #[arg(long, value_name = "ID@N", value_parser = args::fault)]
    pub lose_reply: Option<crate::app::bus::simulator::Fault>,
    /// Servo ID@N reports an overload (and turns its torque off) from the N-th goal packet on.
    #[arg(long, value_name = "ID@N", value_parser = args::fault)]
    pub overload: Option<crate::app::bus::simulator::Fault>,
    /// The joints' angles at the start, rad (the setup's sense; default: the pose `play`
    /// starts a game from).
    #[arg(long, value_name = "Q1,Q2,Q3,Q4", value_parser = args::angles, allow_hyphen_values = true)]
    pub start: Option<[f64; 4]>,
}

#[derive(Debug, Args, Clone)]
pub struct RobustnessArgs {
    /// A PGN game each trial plays whole (instead of the scenario).
    pub game_file: Option<PathBuf>,
    /// Which game of the PGN file, 1-based.
    #[arg(long, default_value_t = 1, value_parser = args::game_number)]
    pub game: usize,
    /// Scenario each trial simulates (without a game).
    #[arg(long, default_value = "queens-gambit")]
    pub scenario: String,
    /// Number of randomised trials.
    #[arg(long, default_value_t = 100, value_parser = args::count)]
    pub trials: usize,
    /// Controllers to compare, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "pd,pid,adaptive,dob")]
    pub controller: Vec<ControllerName>,
    #[command(flatten)]
    pub gains: GainArgs,
    #[command(flatten)]
    pub conditions: ConditionArgs,
    /// Motion limits of a game's moves (a scenario keeps its own LSPB path).
    #[command(flatten)]
    pub motion: MotionArgs,
    /// How a game's pieces are put down.
    #[command(flatten)]
    pub placement: PlacementArgs,
    /// The scenario's pawn mass as the controller believes it, kg (default: the setup's pawn);
    /// its true mass follows the [uncertainty] piece_mass draws.
    #[arg(long, value_parser = args::mass, allow_hyphen_values = true)]
    pub payload_mass: Option<f64>,
    /// The controller's model includes each gripped piece (its true mass).
    #[arg(long)]
    pub controller_knows_payload: bool,
    /// A piece further than this from its square centre is misplaced, mm.
    #[arg(long, default_value_t = 5.0, value_parser = args::positive, allow_hyphen_values = true)]
    pub tolerance_mm: f64,
    /// Integrator of the plant.
    #[arg(long, value_enum, default_value_t)]
    pub integrator: IntegratorChoice,
    /// Run only slice K of N (1-based) of the trials; the slices' CSVs concatenate to the whole.
    #[arg(long, value_parser = args::shard)]
    pub shard: Option<(usize, usize)>,
    /// The speed–accuracy frontier of a game: the same trials at each pace, comma-separated
    /// (the motion's own limits as a uniform speed-up by the pace would scale them: tool speed
    /// × k, accelerations × k², jerk × k³); writes frontier.csv, frontier.png, frontier.json.
    #[arg(long, value_delimiter = ',', value_parser = args::positive, allow_hyphen_values = true)]
    pub paces: Option<Vec<f64>>,
    #[command(flatten)]
    pub batch: BatchArgs,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Output folder.
    #[arg(long, default_value = "out/robustness")]
    pub out: PathBuf,
}

/// How robot moves are timed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TimingChoice {
    /// As fast as every limit allows (TOPP-RA), corners blended, no pauses.
    Optimal,
    /// The report's straight LSPB moves that stop at every corner, with pauses.
    Lspb,
}

/// The motion limits as flags; each overrides the setup file's `[motion]` or `[gripper]`.
#[derive(Debug, Args, Clone)]
pub struct MotionArgs {
    /// How robot moves are timed.
    #[arg(long, value_enum, default_value_t = TimingChoice::Optimal)]
    pub timing: TimingChoice,
    /// Largest tool-tip speed of optimal motions, m/s (default 1).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub tool_speed: Option<f64>,
    /// Largest joint accelerations of optimal motions, rad/s²: one for all joints or 4
    /// comma-separated (default 20).
    #[arg(long, value_delimiter = ',', value_parser = args::positive, allow_hyphen_values = true)]
    pub joint_acceleration: Option<Vec<f64>>,
    /// Share of each motor's torque limit an optimal plan may use, in (0, 1] (default 0.85).
    #[arg(long, value_parser = args::share, allow_hyphen_values = true)]
    pub torque_margin: Option<f64>,
    /// Largest tool acceleration while carrying a piece, m/s² (default 5).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub carry_acceleration: Option<f64>,
    /// Largest |acceleration − gravity| of a carried piece the grip holds, m/s² (default 19.62).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub grip_strength: Option<f64>,
    /// Time to close the gripper, s (default 0.3).
    #[arg(long, value_parser = args::non_negative, allow_hyphen_values = true)]
    pub grip_dwell: Option<f64>,
    /// Time to open the gripper, s (default 0.3).
    #[arg(long, value_parser = args::non_negative, allow_hyphen_values = true)]
    pub release_dwell: Option<f64>,
    /// Largest corner cut of a blend, m (0: stop at every corner; default 0.04).
    #[arg(long, value_parser = args::non_negative, allow_hyphen_values = true)]
    pub blend: Option<f64>,
    /// Clearance over the tallest piece passed over, m (default 0.03).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub clearance_margin: Option<f64>,
    /// Planning grid step along the path, m (default 0.005, at least 1e-4).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub grid_step: Option<f64>,
    /// Pace: the motion's own limits as a uniform speed-up by K would scale them (tool and
    /// LSPB speeds × K, accelerations × K², jerk × K³), after the other flags; the arm's joint
    /// speeds and torques, the grip, the dwells, the pauses and the tracking budget stay
    /// (default 1; robustness --paces multiplies it).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub pace: Option<f64>,
    /// Largest jerk along the path of optimal motions, m/s³: each leg's acceleration steps
    /// are smoothed just enough (0: no limit; default 0).
    #[arg(long, value_parser = args::non_negative, allow_hyphen_values = true)]
    pub jerk: Option<f64>,
    /// Largest tracking error the motion may add while carrying a piece whose true mass differs
    /// from the one the controller is told, m: carrying accelerations are bounded by the
    /// controller's gains and the pieces' mass uncertainty (0: no budget; default 0).
    #[arg(long, value_parser = args::non_negative, allow_hyphen_values = true)]
    pub tracking_budget: Option<f64>,
    /// LSPB traverse speed, m/s (default 0.25).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub traverse_speed: Option<f64>,
    /// LSPB traverse acceleration, m/s² (default 0.8).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub traverse_acceleration: Option<f64>,
    /// LSPB rise and descent speed, m/s (default 0.15).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub vertical_speed: Option<f64>,
    /// LSPB rise and descent acceleration, m/s² (default 0.6).
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub vertical_acceleration: Option<f64>,
    /// Rest between LSPB moves, s (default 0.25).
    #[arg(long, value_parser = args::non_negative, allow_hyphen_values = true)]
    pub pause: Option<f64>,
}

impl MotionArgs {
    /// `setup` with its motion limits overridden by the flags given and the timing set.
    pub fn apply(&self, setup: &crate::app::setup::file::Setup) -> anyhow::Result<crate::app::setup::file::Setup> {
        let mut limits = setup.motion;
        let set = |target: &mut f64, given: Option<f64>| {
            if let Some(value) = given {
                *target = value;
            }
        };
        set(&mut limits.tool_speed, self.tool_speed);
        set(&mut limits.torque_margin, self.torque_margin);
        set(&mut limits.carry_acceleration, self.carry_acceleration);
        set(&mut limits.grip_strength, self.grip_strength);
        set(&mut limits.grip_dwell, self.grip_dwell);
        set(&mut limits.release_dwell, self.release_dwell);
        set(&mut limits.blend, self.blend);
        set(&mut limits.clearance_margin, self.clearance_margin);
        set(&mut limits.grid_step, self.grid_step);
        set(&mut limits.jerk, self.jerk);
        set(&mut limits.tracking.budget, self.tracking_budget);
        set(&mut limits.traverse_speed, self.traverse_speed);
        set(&mut limits.traverse_acceleration, self.traverse_acceleration);
        set(&mut limits.vertical_speed, self.vertical_speed);
        set(&mut limits.vertical_acceleration, self.vertical_acceleration);
        set(&mut limits.pause, self.pause);
        if let Some(values) = &self.joint_acceleration {
            limits.joint_acceleration = match values.as_slice() {
                [one] => [*one; 4],
                [a, b, c, d] => [*a, *b, *c, *d],
                _ => anyhow::bail!("--joint-acceleration takes 1 or 4 values (rad/s²), not {}", values.len()),
            };
        }
        let mut setup = setup.clone();
        setup.motion = crate::app::setup::file::checked_limits(limits, "motion", "gripper")?;
        if let Some(pace) = self.pace {
            setup.motion = crate::app::setup::file::checked_limits(limits.at_pace(pace), "motion", "gripper")
                .map_err(|error| anyhow::anyhow!("--pace {}: {error}", crate::app::resources::show(pace)))?;
        }
        setup.timing = match self.timing {
            TimingChoice::Optimal => chessarm_chess::motion::TimingMode::Optimal,
            TimingChoice::Lspb => chessarm_chess::motion::TimingMode::Lspb,
        };
        Ok(setup)
    }
}

/// How the robot puts pieces down and knows what it carries (games only).
#[derive(Debug, Args, Clone)]
pub struct PlacementArgs {
    /// Close and open the gripper at the plan's instants, whether or not the arm is in
    /// position (the default waits at each grip and release until it is: a fine point).
    #[arg(long)]
    pub release_by_clock: bool,
    /// In position: the estimated tip within this distance of the planned point, mm (default:
    /// two counts of every encoder at the tip, between a twentieth and a tenth of
    /// --tolerance-mm: 0.5 mm with hobby encoders, 0.25 mm with servo ones or ideal sensors).
    #[arg(long, value_name = "MM", value_parser = args::positive, allow_hyphen_values = true)]
    pub in_position_band_mm: Option<f64>,
    /// In position: the estimated tip no faster than this, mm/s (default: the band per 0.1 s).
    #[arg(long, value_name = "MM_PER_S", value_parser = args::positive, allow_hyphen_values = true)]
    pub in_position_speed_mm_s: Option<f64>,
    /// Longest wait for the arm to be in position, s; the gripper then goes ahead and the
    /// wait is reported as timed out (default 1; at most 60).
    #[arg(long, value_name = "S", value_parser = args::wait, allow_hyphen_values = true)]
    pub in_position_timeout: Option<f64>,
    /// Do not tell the controller the nominal mass of the piece kind it grips (the default
    /// feeds it forward; --controller-knows-payload tells it the true mass instead).
    #[arg(long)]
    pub no_payload_feedforward: bool,
}

impl PlacementArgs {
    /// The choices in SI (the flags' mm and mm/s converted here).
    pub fn options(&self) -> crate::app::studies::placement::Placement {
        crate::app::studies::placement::Placement {
            release_by_clock: self.release_by_clock,
            in_position_band: self.in_position_band_mm.map(|band| band / 1e3),
            in_position_speed: self.in_position_speed_mm_s.map(|speed| speed / 1e3),
            in_position_timeout: self.in_position_timeout,
            payload_feedforward: !self.no_payload_feedforward,
        }
    }
}

pub use crate::app::studies::play::RobotSide;

/// How the person's moves arrive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum HumanInput {
    /// Moves typed in SAN or UCI.
    Typed,
    /// The board's occupancy read by its sensors (64 × 0/1 from a1 to h8, a hex bitboard, or a
    /// FEN board field), one reading per line after each move.
    Occupancy,
}

/// The side a person plays (`play --human`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum HumanSide {
    White,
    Black,
}

#[derive(Debug, Args)]
pub struct PlayArgs {
    /// A PGN file to replay (comments and variations are ignored).
    pub game_file: Option<PathBuf>,
    /// Which game of the PGN file, 1-based.
    #[arg(long, default_value_t = 1, value_parser = args::game_number, conflicts_with_all = ["moves", "human"])]
    pub game: usize,
    /// Moves in SAN or UCI, e.g. "e4 e5 Nf3" (instead of a PGN file).
    #[arg(long, conflicts_with = "game_file")]
    pub moves: Option<String>,
    /// Start position as FEN (default: the initial position).
    #[arg(long)]
    pub fen: Option<String>,
    /// Opponent engine when no game is given: "builtin" or the path of a UCI engine.
    #[arg(long, default_value = "builtin")]
    pub engine: String,
    /// Half-moves to play against the engine (the game may end sooner).
    #[arg(long, default_value_t = 120, conflicts_with = "human")]
    pub plies: usize,
    /// Thinking time per move of a UCI engine (--engine PATH), ms: its moves then depend on
    /// the machine's speed, and game.json says so.
    #[arg(long, default_value_t = 100)]
    pub movetime: u64,
    /// Cap on the built-in engine's search time per move, ms. Without it the built-in engine
    /// searches to --depth, so its moves are a function of the position alone; with it they
    /// depend on the machine's speed (game.json says so).
    #[arg(long, value_name = "MS")]
    pub builtin_movetime: Option<u64>,
    /// How long to wait for a UCI engine beyond its thinking time, ms (30 s: Stockfish's start,
    /// which loads its network, took more than 5 s on a busy 2-core machine).
    #[arg(long, default_value_t = 30_000)]
    pub engine_timeout: u64,
    /// Search depth of the built-in engine, plies (1–10: each ply more multiplies the search
    /// time by ~4; depth 7 takes ~1 s a middlegame move here).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=10))]
    pub depth: u32,
    /// The side the arm plays; the other side's pieces are moved by the opponent's hand.
    /// Against an engine the robot's moves come from its built-in engine (with both: all moves from --engine).
    #[arg(long, value_enum, default_value_t = RobotSide::Both)]
    pub robot: RobotSide,
    /// Play against the arm: you play this side, the arm the other with --engine's moves. Your
    /// moves come from standard input (or --input-socket), as --human-input says; `undo`,
    /// `resign`, `draw` and `quit` work too. The game is saved as game.pgn in --out after every
    /// move.
    #[arg(long, value_enum, conflicts_with_all = ["game_file", "moves", "robot"])]
    pub human: Option<HumanSide>,
    /// How your moves arrive: `typed` (SAN or UCI) or `occupancy` (the board's sensors: 64
    /// characters 0/1 from a1 to h8, a 0x bitboard, or a FEN board field, one line after each
    /// move). Default: typed.
    #[arg(long, value_enum, requires = "human")]
    pub human_input: Option<HumanInput>,
    /// Read your moves from a Unix socket chessarm creates at this path (a board's reader
    /// program connects and writes lines) instead of standard input.
    #[arg(long, value_name = "PATH", requires = "human")]
    pub input_socket: Option<PathBuf>,
    /// Read your moves from this file instead of standard input: a recorded session, or a
    /// named pipe (mkfifo) a board's reader program writes into.
    #[arg(long, value_name = "FILE", requires = "human", conflicts_with = "input_socket")]
    pub input_file: Option<PathBuf>,
    /// Serve a live page on 127.0.0.1:PORT (0: any free port; the address is printed): the
    /// arm in 3D, a board to click your moves on (they replace standard input), the move list
    /// and the built-in engine's evaluation.
    #[arg(long, value_name = "PORT", requires = "human", conflicts_with_all = ["input_socket", "input_file"])]
    pub live: Option<u16>,
    /// Go on with the game saved in --out's game.pgn (its start and moves, the board standing
    /// as they leave it).
    #[arg(long, requires = "human")]
    pub resume: bool,
    /// Drive the real arm: the servos (--actuator, `[servo_bus]`) on this serial device, each
    /// robot move's proved goal stream sent at the bus rate, every goal checked on the wire.
    #[arg(long, value_name = "DEVICE")]
    pub port: Option<PathBuf>,
    /// Log the packets the real arm would be sent (--out's bus.jsonl), opening nothing.
    #[arg(long, conflicts_with = "port")]
    pub dry_run: bool,
    /// With --port: the largest distance of a goal from a joint's present position, degrees;
    /// a goal further away stops the arm (torque off).
    #[arg(long, default_value_t = 20.0, value_parser = args::positive, allow_hyphen_values = true)]
    pub max_step_deg: f64,
    /// With --port: how long a servo may take to answer, ms, before the arm is stopped.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub reply_timeout_ms: u64,
    /// Outer loop of the computed-torque controller.
    #[arg(long, value_enum, default_value_t = OneController::Pd)]
    pub controller: OneController,
    #[command(flatten)]
    pub gains: GainArgs,
    /// The controller's model includes each gripped piece.
    #[arg(long)]
    pub controller_knows_payload: bool,
    /// Run every move at the pace given (--pace, default 1), even where its simulated motion
    /// comes nearer than [motion] arm_clearance; by default such a move is run again slower
    /// (0.7× at a time, at most 4 times) and the try that kept clear stands.
    #[arg(long)]
    pub keep_pace: bool,
    #[command(flatten)]
    pub conditions: ConditionArgs,
    #[command(flatten)]
    pub motion: MotionArgs,
    #[command(flatten)]
    pub placement: PlacementArgs,
    /// Integration time step of the plant, s (as `simulate`'s; smaller when a run diverges).
    #[arg(long, default_value_t = 0.001, value_parser = args::positive, allow_hyphen_values = true)]
    pub dt: f64,
    /// Integrator of the plant.
    #[arg(long, value_enum, default_value_t)]
    pub integrator: IntegratorChoice,
    /// A piece further than this from its square centre is misplaced, mm.
    #[arg(long, default_value_t = 5.0, value_parser = args::positive, allow_hyphen_values = true)]
    pub tolerance_mm: f64,
    /// Output folder.
    #[arg(long, default_value = "out/play")]
    pub out: PathBuf,
    /// Sample rate of the planned joint trajectories written for hardware (`hardware/`: ROS 2
    /// JointTrajectory JSON and CSV with the gripper's state), Hz.
    #[arg(long, value_name = "HZ", default_value_t = 100.0, value_parser = args::export_rate, allow_hyphen_values = true)]
    pub export_rate: f64,
}

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("spec").required(true).args(["settling_time", "wn"])))]
pub struct GainsArgs {
    /// Wanted 2 % settling time of the error response, s.
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub settling_time: Option<f64>,
    /// Wanted overshoot of the error response, % (with --settling-time; 0 = critically damped).
    #[arg(long, default_value_t = 0.0, value_parser = args::non_negative, conflicts_with = "wn", allow_hyphen_values = true)]
    pub overshoot: f64,
    /// Natural frequency, rad/s (instead of --settling-time).
    #[arg(long, value_parser = args::positive, requires = "zeta", allow_hyphen_values = true)]
    pub wn: Option<f64>,
    /// Damping ratio (with --wn).
    #[arg(long, value_parser = args::positive, conflicts_with = "settling_time", allow_hyphen_values = true)]
    pub zeta: Option<f64>,
    /// Controller: pd, or pid by pole placement (third pole at −ratio·ωn).
    #[arg(long, value_enum, default_value_t = ControllerChoice::Pd)]
    pub controller: ControllerChoice,
    /// PID only: the integral pole sits at −ratio·ωn. Default: with specs, the ratio that
    /// settles fastest; with --wn/--zeta, 0.2.
    #[arg(long, value_parser = args::positive, allow_hyphen_values = true)]
    pub integral_pole_ratio: Option<f64>,
    /// Scenario simulated to verify the design.
    #[arg(long, default_value = "queens-gambit")]
    pub scenario: String,
    /// Initial error of every joint for the verification run, rad.
    #[arg(long, default_value_t = 0.05, value_parser = args::positive, allow_hyphen_values = true)]
    pub initial_error: f64,
    /// Skip the verification run.
    #[arg(long)]
    pub no_verify: bool,
    #[command(flatten)]
    pub conditions: ConditionArgs,
}

pub use crate::app::studies::tune::Metric;

#[derive(Debug, Args, Clone)]
pub struct TuneArgs {
    /// A PGN game each candidate plays whole (instead of the scenario).
    pub game_file: Option<PathBuf>,
    /// Which game of the PGN file, 1-based.
    #[arg(long, default_value_t = 1, value_parser = args::game_number)]
    pub game: usize,
    /// Scenario to simulate each candidate on.
    #[arg(long, default_value = "queens-gambit")]
    pub scenario: String,
    /// Outer loop to tune.
    #[arg(long, value_enum, default_value_t = OneController::Pd)]
    pub controller: OneController,
    /// kp range A..B:N (N values from A to B), 1/s².
    #[arg(long, value_parser = args::range)]
    pub kp: Option<args::GainRange>,
    /// kd range A..B:N, 1/s.
    #[arg(long, value_parser = args::range)]
    pub kd: Option<args::GainRange>,
    /// ki range A..B:N, 1/s³ (PID only).
    #[arg(long, value_parser = args::range)]
    pub ki: Option<args::GainRange>,
    /// With servos (--actuator): range A..B:N of the servos' P gain register (the value written
    /// to the servo: Feetech P, Dynamixel Position P Gain), swept for each host strategy of
    /// --servo-command (default: plain, sag and feedforward).
    #[arg(long, value_parser = args::range, conflicts_with_all = ["kp", "kd", "ki"])]
    pub p_gain: Option<args::GainRange>,
    /// Mass of the gripped piece, kg, carried from grip to release.
    #[arg(long, default_value_t = 0.0, value_parser = args::mass, allow_hyphen_values = true)]
    pub payload_mass: f64,
    /// The controller's model includes the gripped piece.
    #[arg(long)]
    pub controller_knows_payload: bool,
    #[command(flatten)]
    pub conditions: ConditionArgs,
    /// Motion limits of a game's moves (a scenario keeps its own LSPB path).
    #[command(flatten)]
    pub motion: MotionArgs,
    /// How a game's pieces are put down.
    #[command(flatten)]
    pub placement: PlacementArgs,
    /// Initial joint angles (rad), at rest; default: on the trajectory's first point.
    #[arg(long, value_name = "Q1,Q2,Q3,Q4", value_parser = args::angles, allow_hyphen_values = true)]
    pub q0: Option<[f64; 4]>,
    /// Metric to rank candidates by and to draw.
    #[arg(long, value_enum, default_value_t = Metric::MaxTipError)]
    pub metric: Metric,
    /// Start of the tracking metrics (max/RMS tip and joint errors), s. Default: 1 s with
    /// --q0 (the start from rest off the trajectory is a deliberate transient that would
    /// otherwise dominate them), 0 without.
    #[arg(long, value_name = "S", value_parser = args::non_negative, allow_hyphen_values = true)]
    pub tracking_from: Option<f64>,
    /// Run only slice K of N (1-based), e.g. 2/8; the slices' CSVs concatenate to the full sweep.
    #[arg(long, value_parser = args::shard)]
    pub shard: Option<(usize, usize)>,
    #[command(flatten)]
    pub batch: BatchArgs,
    /// Integrator of the plant.
    #[arg(long, value_enum, default_value_t)]
    pub integrator: IntegratorChoice,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// How many best candidates to print.
    #[arg(long, default_value_t = 5)]
    pub top: usize,
    /// Output folder.
    #[arg(long, default_value = "out/tune")]
    pub out: PathBuf,
}

/// Outer-loop gains given on the command line; the report's are used for what is left out.
#[derive(Debug, Args, Clone, Copy, Default)]
pub struct GainArgs {
    /// Proportional gain, 1/s²: one value or one per joint (a,b,c,d). Default: the report's
    /// (400; PID 600) for scenarios, 2500 for games (play, robustness of a game).
    #[arg(long, value_parser = args::gain, allow_hyphen_values = true)]
    pub kp: Option<[f64; 4]>,
    /// Derivative gain, 1/s: one value or one per joint.
    #[arg(long, value_parser = args::gain, allow_hyphen_values = true)]
    pub kd: Option<[f64; 4]>,
    /// Integral gain (PID), 1/s³: one value or one per joint.
    #[arg(long, value_parser = args::gain, allow_hyphen_values = true)]
    pub ki: Option<[f64; 4]>,
}

impl GainArgs {
    /// The gains as given, for the studies.
    pub fn given(&self) -> crate::app::studies::simulate::GivenGains {
        crate::app::studies::simulate::GivenGains { kp: self.kp, kd: self.kd, ki: self.ki }
    }
}

/// How the plant is integrated over each time step (all fixed-step, torque held per step).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum IntegratorChoice {
    /// Nyström's fourth-order Runge–Kutta: 3 mass matrices and 4 bias evaluations per step.
    #[default]
    Rkn4,
    /// Classical fourth-order Runge–Kutta: 4 of each.
    Rk4,
    /// Explicit midpoint, second order: 2 of each.
    Midpoint,
    /// Semi-implicit Euler, first order (as MuJoCo's default): 1 of each.
    Euler,
}

impl IntegratorChoice {
    pub fn integrator(self) -> chessarm_core::sim::Integrator {
        use chessarm_core::sim::Integrator;
        match self {
            IntegratorChoice::Rkn4 => Integrator::RungeKuttaNystrom4,
            IntegratorChoice::Rk4 => Integrator::RungeKutta4,
            IntegratorChoice::Midpoint => Integrator::Midpoint,
            IntegratorChoice::Euler => Integrator::SemiImplicitEuler,
        }
    }
}

/// One controller (commands that run a single one: `play`, `tune`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OneController {
    /// Computed torque with a PD outer loop (report: kp = 400, kd = 20).
    Pd,
    /// Computed torque with a PID outer loop and anti-windup (report: kp = 600, kd = 25, ki = 75).
    Pid,
    /// Computed torque that estimates the gripped piece's mass online (PD gains).
    Adaptive,
    /// Computed torque with a disturbance observer (PD gains).
    Dob,
}

impl From<OneController> for ControllerName {
    fn from(choice: OneController) -> Self {
        match choice {
            OneController::Pd => ControllerName::Pd,
            OneController::Pid => ControllerName::Pid,
            OneController::Adaptive => ControllerName::Adaptive,
            OneController::Dob => ControllerName::Dob,
        }
    }
}

/// Which controllers to simulate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ControllerChoice {
    /// Computed torque with a PD outer loop (report: kp = 400, kd = 20).
    Pd,
    /// Computed torque with a PID outer loop (report: kp = 600, kd = 25, ki = 75).
    Pid,
    /// Both, compared.
    Both,
}

#[derive(Debug, Args)]
pub struct DynamicsArgs {
    /// Joint angles q1,q2,q3,q4 in rad.
    #[arg(long, value_name = "Q1,Q2,Q3,Q4", value_parser = args::angles, allow_hyphen_values = true)]
    pub q: [f64; 4],
    /// Joint rates in rad/s.
    #[arg(long, value_name = "QD1,QD2,QD3,QD4", value_parser = args::four, allow_hyphen_values = true, default_value = "0,0,0,0")]
    pub qd: [f64; 4],
    /// Mass of a gripped pawn-sized piece at the tool, kg.
    #[arg(long, default_value_t = 0.0, value_parser = args::mass, allow_hyphen_values = true)]
    pub payload_mass: f64,
}

#[derive(Debug, Args, Clone)]
pub struct SimulateArgs {
    /// Built-in scenario.
    #[arg(long, default_value = "queens-gambit")]
    pub scenario: String,
    /// Controllers to simulate, comma-separated (pd, pid, adaptive, dob; both = pd,pid).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "both")]
    pub controller: Vec<ControllerName>,
    #[command(flatten)]
    pub conditions: ConditionArgs,
    #[command(flatten)]
    pub gains: GainArgs,
    /// Integration time step, s.
    #[arg(long, default_value_t = 0.001, value_parser = args::positive, allow_hyphen_values = true)]
    pub dt: f64,
    /// Integrator of the plant.
    #[arg(long, value_enum, default_value_t)]
    pub integrator: IntegratorChoice,
    /// Controller sample rate, Hz (its period must be a multiple of --dt).
    #[arg(long, default_value_t = 1000.0, value_parser = args::positive, allow_hyphen_values = true)]
    pub control_rate: f64,
    /// Initial joint angles (rad), at rest; default: on the trajectory's first point.
    #[arg(long, value_name = "Q1,Q2,Q3,Q4", value_parser = args::angles, allow_hyphen_values = true)]
    pub q0: Option<[f64; 4]>,
    /// Mass of the gripped piece (pawn-sized), kg, carried from grip to release.
    #[arg(long, default_value_t = 0.0, value_parser = args::mass, allow_hyphen_values = true)]
    pub payload_mass: f64,
    /// The controller's model includes the gripped piece.
    #[arg(long)]
    pub controller_knows_payload: bool,
    /// Start of the tracking metrics in summary.json (RMS/max tip and joint errors), s.
    #[arg(long, value_name = "S", default_value_t = 0.0, value_parser = args::non_negative, allow_hyphen_values = true)]
    pub tracking_from: f64,
    /// Output folder.
    #[arg(long, default_value = "out/simulate")]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder (plan/ and simulate/ go inside).
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub struct BoardArgs {
    /// Find the largest board the arm serves and print it as a setup file (use it with --arm).
    #[arg(long)]
    pub fit: bool,
    /// With --fit: place a board of squares of this size (m, e.g. 0.025) where the arm serves
    /// it, instead of the largest; when no pose serves it, which squares and slots fail and
    /// why (--map draws the nearest pose).
    #[arg(long, value_name = "M", value_parser = args::square_size, requires = "fit", allow_hyphen_values = true)]
    pub square_size: Option<args::SquareSize>,
    /// With --fit: write the setup file here (the summary then goes to standard output).
    #[arg(long, value_name = "FILE.toml", requires = "fit")]
    pub save: Option<PathBuf>,
    /// Draw the reach map (per square: the margin, or grey where not served) into this PNG.
    #[arg(long, value_name = "FILE.png")]
    pub map: Option<PathBuf>,
    /// With servos or steppers (--actuator): draw the sag map (per square, the placement error
    /// gravity leaves with plain goals) into this PNG. The table and the torque headroom are
    /// printed with servos whether or not it is given.
    #[arg(long, value_name = "FILE.png")]
    pub sag_map: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct FkArgs {
    /// Joint angles q1,q2,q3,q4 in rad.
    #[arg(long, value_name = "Q1,Q2,Q3,Q4", value_parser = args::angles, allow_hyphen_values = true)]
    pub q: [f64; 4],
}

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("target").required(true).args(["xyz", "square"])))]
pub struct IkArgs {
    /// Tool-tip position x,y,z in m (base frame).
    #[arg(long, value_name = "X,Y,Z", value_parser = args::three, allow_hyphen_values = true)]
    pub xyz: Option<[f64; 3]>,
    /// A board square, e.g. d4; the tip goes --height above its centre.
    #[arg(long)]
    pub square: Option<String>,
    /// Height above the square's centre, m.
    #[arg(long, default_value_t = 0.05, value_parser = args::finite, allow_hyphen_values = true)]
    pub height: f64,
    /// Tool pitch above the horizontal, rad (−π/2: pointing down).
    #[arg(long, default_value_t = -std::f64::consts::FRAC_PI_2, value_parser = args::finite, allow_hyphen_values = true)]
    pub pitch: f64,
}

#[derive(Debug, Args)]
pub struct PlanArgs {
    /// Built-in scenario.
    #[arg(long, default_value = "queens-gambit")]
    pub scenario: String,
    /// Plan these chess moves (SAN or UCI, e.g. "e4 e5") instead of the scenario, each by the
    /// robot with --timing: path, joint trajectory, and a phase-plane plot per move.
    #[arg(long)]
    pub moves: Option<String>,
    /// Start position of --moves as FEN (default: the initial position).
    #[arg(long, requires = "moves")]
    pub fen: Option<String>,
    #[command(flatten)]
    pub motion: MotionArgs,
    /// Output folder.
    #[arg(long, default_value = "out/plan")]
    pub out: PathBuf,
    /// Sample time of the written trajectory, s (the report: 5 ms).
    #[arg(long, default_value_t = 0.005, value_parser = args::positive, allow_hyphen_values = true)]
    pub dt: f64,
    /// Also write joint.xlsx (the report exported a spreadsheet).
    #[arg(long)]
    pub xlsx: bool,
    /// Sample rate of the planned joint trajectories written for hardware (`hardware/`: ROS 2
    /// JointTrajectory JSON and CSV with the gripper's state), Hz.
    #[arg(long, value_name = "HZ", default_value_t = 100.0, value_parser = args::export_rate, allow_hyphen_values = true)]
    pub export_rate: f64,
}

/// Sensor, actuator and model-error options, the same on every command that simulates.
#[derive(Debug, Args, Clone, Default)]
pub struct ConditionArgs {
    /// Sensors: ideal (the exact state), hobby (12-bit encoders, σ 0.5 count, 1 sample delay),
    /// servo (17-bit, σ 0.5 count), a profile of the setup file's [sensors.NAME] tables, or a
    /// TOML FILE of one profile (counts_per_rev, noise_counts, offset, delay_samples, rate_noise).
    #[arg(long, value_name = "PROFILE|FILE")]
    pub sensors: Option<String>,
    /// State estimator. Default: direct with ideal sensors, kalman otherwise.
    #[arg(long, value_enum)]
    pub estimator: Option<EstimatorChoice>,
    /// σ of the acceleration the Kalman filter's motion model does not know, rad/s².
    #[arg(long, value_name = "RAD_PER_S2", value_parser = args::positive, allow_hyphen_values = true)]
    pub kalman_acceleration_noise: Option<f64>,
    /// Time constant of the low-pass of the lowpass estimator, s.
    #[arg(long, value_name = "S", value_parser = args::non_negative, allow_hyphen_values = true)]
    pub lowpass_time_constant: Option<f64>,
    /// Motors' first-order torque lag, s: one value or one per joint (default 0: none).
    #[arg(long, value_name = "S", value_parser = args::time_constants, allow_hyphen_values = true)]
    pub torque_lag: Option<[f64; 4]>,
    /// The controller is told --arm's friction (viscous, coulomb) and compensates it; without
    /// it, friction acts in the plant only. The default with --urdf (the file's <dynamics> are
    /// part of its model).
    #[arg(long, conflicts_with = "controller_ignores_friction")]
    pub controller_knows_friction: bool,
    /// With --urdf: the controller does not compensate the file's <dynamics> friction (it acts
    /// in the plant only), as without --urdf.
    #[arg(long)]
    pub controller_ignores_friction: bool,
    /// The true arm and pieces: a second setup file (the controller keeps --arm's model).
    #[arg(long, value_name = "FILE")]
    pub plant: Option<PathBuf>,
    /// Random model errors: a TOML file with the fields of an [uncertainty] table (default:
    /// the setup file's [uncertainty] table, if any).
    #[arg(long, value_name = "FILE")]
    pub uncertainty: Option<PathBuf>,
    /// Seed of the sensor noise and the model draws of a run (robustness: of the study).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Run one trial of `robustness` alone: the trial_seed of its row in robustness.csv.
    #[arg(long, value_name = "SEED", conflicts_with = "seed")]
    pub trial_seed: Option<u64>,
}

impl ConditionArgs {
    /// The options as given, for the studies.
    pub fn options(&self) -> ConditionOptions {
        ConditionOptions {
            sensors: self.sensors.clone(),
            estimator: self.estimator,
            kalman_acceleration_noise: self.kalman_acceleration_noise,
            lowpass_time_constant: self.lowpass_time_constant,
            torque_lag: self.torque_lag,
            controller_knows_friction: self.controller_knows_friction,
            controller_ignores_friction: self.controller_ignores_friction,
            plant: self.plant.clone(),
            uncertainty: self.uncertainty.clone(),
            seed: self.seed,
            trial_seed: self.trial_seed,
        }
    }
}
