//! `postwarp methods`: list every reconstruction and hole fill with a line
//! on what it does and the paper it comes from.

use crate::methods::{hole_fills, reconstructions};

/// Flags of `postwarp methods` (none).
#[derive(clap::Args, Debug)]
pub struct Args {}

pub fn run(_a: Args) -> anyhow::Result<()> {
    print!("{}", listing());
    Ok(())
}

/// The listing text.
pub fn listing() -> String {
    let mut s = String::from("reconstructions (--method NAME):\n");
    for m in reconstructions() {
        let i = m.info();
        s += &format!(
            "  {:<22} {}\n  {:<22} paper: {}; primitives: {}; default hole fill: {}\n",
            i.name, i.description, "", i.paper, i.primitive, i.default_hole_fill
        );
    }
    s += "hole fills (--hole-fill NAME):\n";
    for f in hole_fills() {
        let i = f.info();
        s += &format!("  {:<22} {}\n  {:<22} paper: {}\n", i.name, i.description, "", i.paper);
    }
    s
}
