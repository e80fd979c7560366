//! Every end-to-end test in one binary, a module per subject (run one subject with
//! `cargo test --test suite <module>::`). One binary links the library and the Rerun SDK once,
//! where a binary per file linked them 29 times: most of a clean `cargo test`'s build time.

mod common;

mod any_pose;
mod ball;
mod cli;
mod clock;
mod declared_sensor;
mod disk;
mod disturb;
mod dynamics;
mod edge;
mod export;
mod full_profile;
mod fuzz;
mod golden;
mod hardening;
mod imperfection;
mod independent;
mod methods;
mod on_the_move;
mod plot;
mod readme;
mod reference;
mod refine;
mod rerun;
mod robot;
mod scenario;
mod sensor;
mod slurm;
mod sweep;
mod time_stamps;
mod tooling;
mod verdict;
mod view;
