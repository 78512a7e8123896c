//! `mesopush-fwsim`: placeholder replaced below.
fn main() {}
