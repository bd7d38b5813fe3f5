//! The launcher's subcommands, one module each: `run` (the whole stack on a scenario),
//! `replay` (a recorded data set through the stack), `compare` (many runs through the
//! processes, tabled), `monte-carlo` (many runs in process), `ungm` (the UNGM benchmark),
//! `bench` (performance figures), `test` (your own publisher through the service and the
//! client, judged by expectations), `map-get` (a running stack's map), `scenarios` and
//! `extraction-report`; `launch` holds what `run` and `replay` share.

pub mod bench;
pub mod compare;
pub mod extraction_report;
pub mod launch;
pub mod map_get;
pub mod monte_carlo;
pub mod replay;
pub mod run;
pub mod scenarios;
pub mod test;
pub mod ungm;
