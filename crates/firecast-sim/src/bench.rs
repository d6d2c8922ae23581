//! The benchmark scenarios, shared by `firecast bench sim` and the simulator's timing test so
//! both measure the same thing.

use crate::automaton::{KernelConfig, Wind};
use crate::env::{Action, EnvConfig, Termination};
use crate::rothermel::FuelMoisture;

/// The fixed action cycle the benchmark feeds every environment.
pub const ACTIONS: [Action; 8] = [
    Action::South,
    Action::East,
    Action::Drop,
    Action::North,
    Action::West,
    Action::Drop,
    Action::South,
    Action::East,
];

/// FireCastRL's defaults (Concord kernel) under a 10 mi/h south-westerly. Episodes end as soon
/// as nothing burns, so every timed step has a fire.
pub fn firecastrl_config() -> EnvConfig {
    let mut cfg = EnvConfig {
        termination: Termination::NoBurningCells,
        ..EnvConfig::default()
    };
    cfg.sim.wind = Wind {
        speed_mph: 10.0,
        from_direction_deg: 225.0,
        ..Wind::default()
    };
    cfg
}

/// A large wind-driven fire: behave's Rothermel kernel on dry summer fuels, same wind.
pub fn large_fire_config() -> EnvConfig {
    let mut cfg = firecastrl_config();
    cfg.sim.kernel = KernelConfig::Rothermel {
        moisture: FuelMoisture::from_percent(5.0, 6.0, 8.0, 60.0, 90.0),
        drop_moisture_increment: 0.05,
    };
    cfg
}
