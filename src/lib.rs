//! The launcher's library: what its commands share with each other and with the
//! integration tests — the service settings of a run ([`settings`]), the estimators a
//! comparison runs ([`grid`]) and the in-process pipeline of the Monte Carlo comparison
//! ([`offline`]).

pub mod grid;
pub mod offline;
pub mod settings;
