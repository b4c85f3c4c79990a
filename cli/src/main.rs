// Library-style modules, wired into commands by the CLI's main (dead code until then).
#[allow(dead_code)]
mod robot_file;

fn main() {}
