//! The push-back solved in parts gives the whole solve's answer bit for bit (`contact::pushback`,
//! "Sweeps in cells"): the property the coupling layer relies on to spread the push-back over
//! ranks without its answer depending on the cuts.
//!
//! Reference: `push_back` on the whole box (itself checked against analytic answers and
//! Newton's third law in pushback.rs, corners.rs and rebound.rs). The parts run `push_back_in` in
//! threads, each on its share of the cells (the cells dealt to parts by a hash of their index,
//! three different deals), exchanging after each colour only the impulses of nodes another part
//! touches, exactly as ranks do through MPI. Every force on a node a part touches, and every
//! normal force, must equal the whole solve's to the last bit (tolerance 0), with friction and
//! without.

mod common;

use common::{crowded_box, Rng};
use contact::{
    cells_of, push_back, push_back_in, Cells, Contact, ContactBox, Exchange, PushBackParams,
    COLOURS, V3,
};
use std::sync::{Arc, Barrier, Mutex};

/// The parts' meeting point: a slot per part for the maxima, one impulse table per node.
struct Shared {
    barrier: Barrier,
    maxima: Mutex<Vec<f64>>,
    impulse: Mutex<Vec<V3>>,
}

/// One part's [`Exchange`] through `Shared`: after colour c it publishes the nodes its contacts of
/// colour c touch, and takes the nodes other parts' contacts of colour c touch that it touches.
struct Threads {
    part: usize,
    shared: Arc<Shared>,
    writes: [Vec<usize>; COLOURS],
    reads: [Vec<usize>; COLOURS],
}

impl Exchange for Threads {
    fn max(&mut self, x: f64) -> f64 {
        self.shared.maxima.lock().unwrap()[self.part] = x;
        self.shared.barrier.wait();
        let m = self
            .shared
            .maxima
            .lock()
            .unwrap()
            .iter()
            .fold(f64::MIN, |a, &b| a.max(b));
        self.shared.barrier.wait();
        m
    }

    fn sync(&mut self, colour: usize, impulse: &mut [V3]) {
        {
            let mut s = self.shared.impulse.lock().unwrap();
            for &j in &self.writes[colour] {
                s[j] = impulse[j];
            }
        }
        self.shared.barrier.wait();
        {
            let s = self.shared.impulse.lock().unwrap();
            for &j in &self.reads[colour] {
                impulse[j] = s[j];
            }
        }
        self.shared.barrier.wait();
    }
}

/// The nodes of contact `c`.
fn nodes_of(b: &ContactBox, c: &Contact) -> Vec<usize> {
    let mut v = vec![c.node as usize];
    v.extend(b.faces.nodes[c.face as usize].iter().map(|&i| i as usize));
    v
}

/// Solves `contacts` in `parts` parts (cells dealt by `deal`), returns per part the forces and
/// the normal forces (aligned with `contacts`, 0 where another part has the contact).
fn solve_in_parts(
    b: &ContactBox,
    contacts: &[Contact],
    params: &PushBackParams,
    parts: usize,
    deal: u64,
) -> Vec<(Vec<usize>, Vec<V3>, Vec<f64>)> {
    let cell = cells_of(b, contacts, params.same_point_tol);
    let part_of = |k: usize| {
        let h = cell[k]
            .iter()
            .fold(deal, |h, &i| (h ^ i as u64).wrapping_mul(0x100_0000_01b3));
        (h >> 17) as usize % parts
    };
    // Which parts touch each node in each colour.
    let n = b.nodes.len();
    let mut touch = vec![[usize::MAX; COLOURS]; n];
    let mut touched_by = vec![vec![false; parts]; n];
    for (k, c) in contacts.iter().enumerate() {
        let (p, col) = (part_of(k), Cells::colour(cell[k]));
        for j in nodes_of(b, c) {
            assert!(
                touch[j][col] == usize::MAX || touch[j][col] == p,
                "two parts touch node {j} in colour {col}: the cells' colouring failed"
            );
            touch[j][col] = p;
            touched_by[j][p] = true;
        }
    }
    let shared = Arc::new(Shared {
        barrier: Barrier::new(parts),
        maxima: Mutex::new(vec![0.0; parts]),
        impulse: Mutex::new(vec![[0.0; 3]; n]),
    });
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..parts)
            .map(|p| {
                let mine: Vec<usize> = (0..contacts.len()).filter(|&k| part_of(k) == p).collect();
                let my_contacts: Vec<Contact> = mine.iter().map(|&k| contacts[k]).collect();
                let my_cells: Vec<[i64; 3]> = mine.iter().map(|&k| cell[k]).collect();
                let writes =
                    std::array::from_fn(|c| (0..n).filter(|&j| touch[j][c] == p).collect());
                let reads = std::array::from_fn(|c| {
                    (0..n)
                        .filter(|&j| {
                            touched_by[j][p] && touch[j][c] != p && touch[j][c] != usize::MAX
                        })
                        .collect()
                });
                let mut ex = Threads {
                    part: p,
                    shared: Arc::clone(&shared),
                    writes,
                    reads,
                };
                let touched: Vec<usize> = (0..n).filter(|&j| touched_by[j][p]).collect();
                s.spawn(move || {
                    let pb = push_back_in(b, &my_contacts, &my_cells, params, &mut ex);
                    let mut normal = vec![0.0; contacts.len()];
                    for (i, &k) in mine.iter().enumerate() {
                        normal[k] = pb.normal_force[i];
                    }
                    (touched, pb.force, normal)
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

#[test]
fn a_push_back_in_parts_equals_the_whole_bit_for_bit() {
    let mut rng = Rng(57);
    let mut shared_nodes = 0;
    for friction in [0.0, 0.4] {
        let (b, contacts) = crowded_box(&mut rng, 80, 40, 500);
        assert!(contacts.len() > 100, "a crowded scene: {}", contacts.len());
        let params = PushBackParams {
            friction,
            ..PushBackParams::new(1e-3)
        };
        let whole = push_back(&b, &contacts, &params);
        for (parts, deal) in [(2, 1u64), (3, 7), (4, 99)] {
            let got = solve_in_parts(&b, &contacts, &params, parts, deal);
            let mut normal = vec![0.0; contacts.len()];
            let mut seen = vec![0usize; b.nodes.len()];
            for (touched, force, nf) in &got {
                for &j in touched {
                    seen[j] += 1;
                    assert_eq!(
                        force[j].map(f64::to_bits),
                        whole.force[j].map(f64::to_bits),
                        "node {j}: the force of {parts} parts (friction {friction}) equals the whole solve's to the bit"
                    );
                }
                for (t, v) in normal.iter_mut().zip(nf) {
                    *t += v;
                }
            }
            for (k, (a, w)) in normal.iter().zip(&whole.normal_force).enumerate() {
                assert_eq!(
                    a.to_bits(),
                    w.to_bits(),
                    "contact {k}: normal force in {parts} parts equals the whole solve's"
                );
            }
            shared_nodes += seen.iter().filter(|&&s| s > 1).count();
        }
    }
    assert!(
        shared_nodes > 50,
        "the parts share nodes (the test exercises the exchange): {shared_nodes}"
    );
}
