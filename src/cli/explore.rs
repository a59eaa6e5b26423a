//! `jeffcott explore`: starts the explorer's local web server (crate::explore) and opens
//! its page.

use super::LaneArgs;
use crate::explore::views::Base;
use crate::explore::{Explorer, ExplorerConfig};
use clap::Args;
use jeffcott_analysis::backend::Engine;
use jeffcott_core::error::Result;
use std::net::{IpAddr, Ipv4Addr};
use std::path::PathBuf;

/// Arguments of `jeffcott explore`.
#[derive(Args, Debug)]
pub struct ExploreArgs {
    /// Address to listen on [default: 127.0.0.1, this machine only]. Any other address
    /// (e.g. 0.0.0.0 to be reached from other machines) makes every request carry the
    /// token printed at start.
    #[arg(long, value_name = "ADDRESS")]
    pub host: Option<IpAddr>,
    /// Port to listen on (0: any free port).
    #[arg(long, default_value_t = 8137)]
    pub port: u16,
    /// Print the page's address without opening a browser.
    #[arg(long)]
    pub no_browser: bool,
    #[command(flatten)]
    pub run: LaneArgs,
    /// Directory for what the page saves (created when something is saved).
    #[arg(long, value_name = "DIR", default_value = "jeffcott-out/explore")]
    pub out: PathBuf,
}

/// Runs `jeffcott explore` until interrupted (Ctrl-C).
pub fn run_explore(args: &ExploreArgs) -> Result<()> {
    let precision = args.run.precision();
    let base = Base {
        params: args.run.model.params()?,
        stepper: args.run.stepper.config(),
        precision,
        backend: args.run.backend,
    };
    base.stepper.validate()?;
    let engine = Engine::new(args.run.backend, precision)?;
    let device = engine.device().to_string();
    let explorer = Explorer::start(ExplorerConfig {
        host: args.host.unwrap_or(IpAddr::V4(Ipv4Addr::LOCALHOST)),
        port: args.port,
        require_token: args.host.is_some(),
        base,
        engine,
        out: args.out.clone(),
    })?;
    let url = explorer.url();
    println!("jeffcott explore: {url}");
    println!("lanes on {device}, {precision:?}; Ctrl-C stops the server");
    if !args.no_browser && webbrowser::open(&url).is_err() {
        println!("(no browser could be opened; open the address above)");
    }
    explorer.serve();
    Ok(())
}
