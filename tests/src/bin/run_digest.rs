//! A run's results in one number ([`tdyn_tests::run_digest`]): the same digest on every CPU
//! and at every rank count is the one-answer guarantee (docs/scene.md "One answer").
//!
//! `cargo run --release -p tdyn-tests --bin run_digest -- OUT_DIR`
fn main() {
    let Some(dir) = std::env::args().nth(1) else {
        eprintln!("usage: run_digest OUT_DIR");
        std::process::exit(2);
    };
    println!("{}", tdyn_tests::run_digest(std::path::Path::new(&dir)));
}
