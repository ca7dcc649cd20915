# Two commands (README): `make run` runs the default scene on 2 ranks, `make test` runs the tests.
# Both install the system packages they need first (scripts/setup.sh). The default scene couples
# all three parts of the paper: a water slug (SPH) strikes a clamped plate (FE) through contact,
# about 10 s of run on 2 cores; the run ends by naming its outputs and out/slug_on_plate/energies.png.
NP ?= 2
SCENE ?= scenes/slug_on_plate.toml
# mpirun as root (CI, containers) and more ranks than cores (tests at np 3 and 4 on 2 cores).
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
export OMPI_MCA_rmaps_base_oversubscribe := 1

.PHONY: setup run test bench lint validate
setup:
	./scripts/setup.sh

run: setup
	mpirun -np $(NP) target/release/tdyn run $(SCENE)

test: setup
	cargo test --release --workspace

bench: setup
	./scripts/bench_fe.sh
	./scripts/bench_sph.sh

# The lint gate (CI runs it after setup, before the tests): formatting, clippy, and the API
# documentation built without a warning (no broken or private links).
lint:
	@cargo fmt --version >/dev/null 2>&1 && cargo clippy --version >/dev/null 2>&1 || rustup component add rustfmt clippy
	cargo fmt --all -- --check
	cargo clippy --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --workspace --quiet

# The validation suite (docs/validation.md): every case of validation/ at its validation
# resolution; out/validation/report.md. FAST=1 runs the coarse meshes the tests use.
validate: setup
	cargo build --release -p tdyn --bins
	target/release/tdyn validate --np $(NP) $(if $(FAST),--fast,)
