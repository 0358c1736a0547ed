//! Tests of the remembered orderings.

use super::*;
use crate::active_set::system::{kkt_matrix, ActiveSystem, Factor};
use crate::active_set::test_problems::{random_problem, solve_gap};
use crate::active_set::{solve, Options, Start};

/// The KKT nodes of a sparse factor, position by position, named as `record` names them.
fn factored_nodes(system: &ActiveSystem, keys: &[RowKey], names: &[usize]) -> Vec<Node> {
    let Factor::Sparse(ldl) = &system.factor else {
        panic!("a sparse factor");
    };
    let u = system.unknowns.base;
    ldl.perm()
        .iter()
        .map(|&l| {
            if l < u {
                Node::Unknown(names[system.unknowns.global[l]])
            } else {
                Node::Row(keys[system.support[l - u]])
            }
        })
        .collect()
}

#[test]
fn a_remembered_ordering_keeps_the_order_of_known_nodes_puts_new_ones_last_and_solves_alike() {
    let keys: Vec<RowKey> = (0..35)
        .map(|i| RowKey {
            family: 3,
            member: 1000 + i,
        })
        .collect();
    let p = random_problem().with_row_keys(keys.clone()).unwrap();
    // Unknown j of this problem is unknown 100 + j of a larger one.
    let names: Vec<usize> = (100..140).collect();
    let mut orderings = Orderings::default();
    let base: Vec<usize> = (0..30).collect();
    let mut memory = Memory {
        orderings: &mut orderings,
        unknowns: &names,
    };
    let first = ActiveSystem::sparse_ordered(&p, &base, Some(&mut memory)).unwrap();
    assert_eq!(memory.orderings.stats(), (1, 0));
    // The fill remembered is the factor's entries per entry of the matrix's upper triangle.
    let Factor::Sparse(ldl) = &first.factor else {
        panic!("a sparse factor");
    };
    let kkt = kkt_matrix(&first.rows, &first.unknowns);
    let fill = ldl.entries_below_diagonal() as f64 / kkt.nnz() as f64;
    assert!(fill > 0.0 && fill.fract() != 0.0, "{fill}");
    assert_eq!(memory.orderings.amd_fill, fill);
    let before = factored_nodes(&first, &keys, &names);
    // Row 5 leaves, row 31 joins: the next factorization is ordered from memory.
    let next: Vec<usize> = (0..30).filter(|&i| i != 5).chain([31]).collect();
    let mut second = ActiveSystem::sparse_ordered(&p, &next, Some(&mut memory)).unwrap();
    assert_eq!(memory.orderings.stats(), (1, 1));
    let after = factored_nodes(&second, &keys, &names);
    let known: Vec<Node> = before
        .iter()
        .copied()
        .filter(|n| after.contains(n))
        .collect();
    let new: Vec<Node> = after
        .iter()
        .copied()
        .filter(|n| !before.contains(n))
        .collect();
    assert!(new.contains(&Node::Row(keys[31])), "{new:?}");
    // Known nodes first, in their remembered order, then the new ones.
    assert_eq!(after[..known.len()], known[..]);
    assert_eq!(after[known.len()..], new[..]);
    let gap = solve_gap(&p, &mut second, &next);
    assert!(gap < 1e-12, "gap {gap:e}");
    // Without keys nothing is remembered or reused.
    let unkeyed = random_problem();
    let mut memory = Memory {
        orderings: &mut orderings,
        unknowns: &names,
    };
    ActiveSystem::sparse_ordered(&unkeyed, &next, Some(&mut memory)).unwrap();
    assert_eq!(orderings.stats(), (1, 1));
}

#[test]
fn without_a_name_per_unknown_the_method_solves_without_memory() {
    let keys: Vec<RowKey> = (0..35)
        .map(|i| RowKey {
            family: 1,
            member: i,
        })
        .collect();
    let p = random_problem().with_row_keys(keys).unwrap();
    let start = || Start {
        support: (0..30).collect(),
        lambda: vec![1.0; 30],
        join: vec![1.0; 35],
        join_at_most: None,
    };
    let mut orderings = Orderings::default();
    let names: Vec<usize> = (0..39).collect();
    let memory = Memory {
        orderings: &mut orderings,
        unknowns: &names,
    };
    let options = Options {
        cap: 200,
        memory: Some(memory),
        ..Options::default()
    };
    let remembering = solve(&p, start(), options).unwrap();
    assert_eq!(
        orderings.stats(),
        (0, 0),
        "nothing ordered from or into memory"
    );
    let plain = solve(&p, start(), Options::capped(200)).unwrap();
    assert_eq!(remembering.x, plain.x);
}

#[test]
fn an_ordering_is_reused_while_most_nodes_are_known_and_its_fill_stays_near_amds() {
    let nodes: Vec<Node> = (0..4).map(Node::Unknown).collect();
    let mut o = Orderings::default();
    assert_eq!(o.ordering(&nodes), None, "nothing remembered");
    o.record(&nodes, &[2, 0, 3, 1], 1.0, false);
    assert_eq!(o.ordering(&nodes), Some(vec![2, 0, 3, 1]));
    // Half the nodes known is enough; fewer is not. New nodes go last, in their order.
    let half = [
        Node::Unknown(9),
        Node::Unknown(3),
        Node::Unknown(8),
        Node::Unknown(0),
    ];
    assert_eq!(o.ordering(&half), Some(vec![3, 1, 0, 2]));
    assert_eq!(o.ordering(&half[..3]), None);
    // A reused ordering filling up to STALE_FILL times AMD's keeps being reused …
    o.record(&nodes, &[2, 0, 3, 1], 1.25, true);
    assert!(o.ordering(&nodes).is_some());
    // … beyond it, the next factorization runs AMD, after which reuse resumes.
    o.record(&nodes, &[2, 0, 3, 1], 1.26, true);
    assert_eq!(o.ordering(&nodes), None);
    o.record(&nodes, &[0, 1, 2, 3], 2.0, false);
    assert_eq!(o.ordering(&nodes), Some(vec![0, 1, 2, 3]));
    o.record(&nodes, &[0, 1, 2, 3], 2.4, true);
    assert!(
        o.ordering(&nodes).is_some(),
        "relative to the last AMD fill"
    );
    assert_eq!(o.stats(), (2, 3));
}

proptest::proptest! {
    /// Placed in a table by rank (ranks spanning few nodes) or sorted (spanning many), the
    /// remembered nodes come in the order of their ranks, and the others after them in
    /// their own order.
    #[test]
    fn an_ordering_lists_nodes_by_rank_then_the_unremembered(
        rounds in proptest::collection::vec(
            (proptest::collection::btree_set(0usize..300, 1..120), 0usize..120),
            1..6,
        ),
        query in proptest::collection::btree_set(0usize..400, 1..60),
        shuffle in proptest::collection::vec(proptest::num::usize::ANY, 60),
    ) {
        let mut o = Orderings::default();
        for (ids, rotation) in &rounds {
            let nodes: Vec<Node> = ids.iter().copied().map(Node::Unknown).collect();
            let perm: Vec<usize> =
                (0..nodes.len()).map(|p| (p + rotation) % nodes.len()).collect();
            o.record(&nodes, &perm, 1.0, false);
        }
        // The query in a scrambled order, so that its own order is not its ranks'.
        let mut ids: Vec<usize> = query.into_iter().collect();
        let len = ids.len();
        for (i, &r) in shuffle.iter().enumerate().take(len) {
            ids.swap(i, r % len);
        }
        let nodes: Vec<Node> = ids.iter().copied().map(Node::Unknown).collect();
        let mut ranked: Vec<(u64, usize)> = nodes
            .iter()
            .enumerate()
            .filter_map(|(l, node)| o.ranks.get(node).map(|&rank| (rank, l)))
            .collect();
        let known = ranked.len();
        ranked.sort_unstable();
        let mut expected: Vec<usize> = ranked.into_iter().map(|(_, l)| l).collect();
        expected.extend((0..nodes.len()).filter(|&l| !o.ranks.contains_key(&nodes[l])));
        let enough = known as f64 >= REMEMBERED_FRACTION * nodes.len() as f64;
        proptest::prop_assert_eq!(o.ordering(&nodes), enough.then_some(expected));
    }
}

#[test]
fn an_ordering_is_by_rank_whether_its_ranks_are_placed_or_sorted() {
    let hundred: Vec<Node> = (0..100).map(Node::Unknown).collect();
    let mut o = Orderings::default();
    o.record(&hundred, &(0..100).rev().collect::<Vec<_>>(), 1.0, false);
    // Ranks 0 and 99, of three nodes: a span of 33 per node, sorted.
    let far = [Node::Unknown(0), Node::Unknown(500), Node::Unknown(99)];
    assert_eq!(o.ordering(&far), Some(vec![2, 0, 1]));
    // Ranks 49 to 51: placed.
    let near = [Node::Unknown(50), Node::Unknown(48), Node::Unknown(49)];
    assert_eq!(o.ordering(&near), Some(vec![0, 2, 1]));
    // No nodes: an empty ordering, as the sort gave.
    assert_eq!(o.ordering(&[]), Some(Vec::new()));
}

#[test]
fn orderings_forget_nodes_not_placed_since_the_call_before_last() {
    let a: Vec<Node> = (0..4).map(Node::Unknown).collect();
    let b: Vec<Node> = (10..14).map(Node::Unknown).collect();
    let mut o = Orderings::default();
    o.record(&a, &[0, 1, 2, 3], 1.0, false);
    o.forget_older();
    o.record(&b, &[0, 1, 2, 3], 1.0, false);
    assert!(o.ordering(&a).is_some() && o.ordering(&b).is_some());
    o.forget_older();
    // `a` was placed before the call before last, `b` since.
    assert_eq!(o.ordering(&a), None);
    assert!(o.ordering(&b).is_some());
    o.forget_older();
    assert!(o.ranks.is_empty());
}

#[test]
fn forks_joined_in_order_rank_their_nodes_after_the_memory_and_each_other() {
    let u = |j: usize| Node::Unknown(j);
    let mut main = Orderings::default();
    main.record(&[u(0), u(1), u(2)], &[2, 0, 1], 2.0, false);
    main.record(&[u(0), u(1), u(2)], &[2, 0, 1], 2.1, true);
    let (mut a, mut b, idle) = (main.fork(), main.fork(), main.fork());
    // A fork orders from the memory as it stood, and counts only its own factorizations.
    let known = [u(0), u(1), u(2)];
    assert_eq!(a.ordering(&known), Some(vec![2, 0, 1]));
    assert_eq!(a.ordering(&known), main.ordering(&known));
    assert_eq!((a.stats(), main.stats()), ((0, 0), (1, 1)));
    // Fork `a` orders two of the memory's nodes anew (AMD); fork `b` two new nodes from
    // memory.
    a.record(&[u(0), u(1)], &[1, 0], 3.0, false);
    b.record(&[u(5), u(6)], &[0, 1], 1.5, true);
    main.join(a);
    // `a` ran AMD: the fill the next orderings are held to is its own.
    assert_eq!(main.amd_fill, 3.0);
    main.join(b);
    assert_eq!(main.stats(), (2, 2));
    // u2 keeps its rank; u1 and u0 as fork `a` placed them, then fork `b`'s nodes, each
    // rank handed out once.
    assert_eq!(
        main.ordering(&[u(0), u(1), u(2), u(5)]),
        Some(vec![2, 1, 0, 3])
    );
    assert_eq!(main.ordering(&[u(6), u(5)]), Some(vec![1, 0]));
    assert_eq!(main.next, 6 + 2 + 2);
    let mut ranks: Vec<u64> = main.ranks.values().copied().collect();
    ranks.sort_unstable();
    assert_eq!(ranks, vec![3, 6, 7, 8, 9]);
    // The last fork that factored sets the fill and staleness the next orderings are held
    // to (`b` reused an ordering: the AMD fill it was held to stays `main`'s 2.0).
    assert_eq!((main.amd_fill, main.stale), (2.0, false));
    // A fork that factored nothing changes nothing, though made before the others joined.
    main.amd_fill = 3.5;
    main.join(idle);
    assert_eq!((main.amd_fill, main.stats(), main.next), (3.5, (2, 2), 10));
}
