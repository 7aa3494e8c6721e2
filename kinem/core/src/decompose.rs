//! The structural decomposition of a model, once per model (issue 31): from
//! the Jacobian's pattern with the drivers, a maximum matching of rows to
//! coordinates and the strongly connected components (Tarjan) of the graph
//! it induces order the unknowns block-triangularly (Dulmage-Mendelsohn's
//! fine decomposition of a square structurally nonsingular pattern): the
//! coordinates fixed by ground and drivers first, then each block that must
//! be solved together (a dyad, a loop), each depending only on earlier ones.
//! Phi_q permuted to the blocks' rows and coordinates in order is block
//! lower triangular with irreducible diagonal blocks.

/// What the pattern allows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// square and structurally nonsingular: the blocks are exact
    Exact,
    /// square but structurally singular (no perfect matching): one block
    Singular,
    /// more equations than coordinates (redundant constraints): one block
    Redundant,
    /// fewer equations than coordinates (drivers missing): one block
    Underdetermined,
}

impl Kind {
    pub fn message(self) -> &'static str {
        match self {
            Kind::Exact => "block-triangular",
            Kind::Singular => "structurally singular: no row for every coordinate, solved as one block",
            Kind::Redundant => "more equations than coordinates (redundant): solved as one block",
            Kind::Underdetermined => "fewer equations than coordinates: solved as one block",
        }
    }
}

/// One diagonal block: its rows and coordinates (ascending coordinates;
/// rows[k] is matched to cols[k], so the block's diagonal is structurally
/// non-zero when the decomposition is exact).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Block {
    pub rows: Vec<usize>,
    pub cols: Vec<usize>,
}

/// The blocks in solve order and what the pattern allows.
#[derive(Clone, Debug)]
pub struct Decomposition {
    pub blocks: Vec<Block>,
    pub kind: Kind,
    /// the structural rank (the maximum matching's size)
    pub rank: usize,
}

const NONE: usize = usize::MAX;

/// Compressed lists: item i's entries are flat[start[i]..start[i + 1]].
fn lists(count: usize, pairs: impl Iterator<Item = (usize, usize)> + Clone) -> (Vec<usize>, Vec<usize>) {
    let mut start = vec![0usize; count + 1];
    for (i, _) in pairs.clone() {
        start[i + 1] += 1;
    }
    for i in 0..count {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut flat = vec![0usize; start[count]];
    for (i, v) in pairs {
        flat[fill[i]] = v;
        fill[i] += 1;
    }
    (start, flat)
}

/// A maximum matching of rows to columns (row_of[c]: the row matched to
/// column c, NONE for none): greedy, then an augmenting path (depth first)
/// from every unmatched row.
pub fn matching(m: usize, n: usize, start: &[usize], adj: &[usize]) -> Vec<usize> {
    let (mut row_of, mut col_of) = (vec![NONE; n], vec![NONE; m]);
    for r in 0..m {
        if let Some(&c) = adj[start[r]..start[r + 1]].iter().find(|&&c| row_of[c] == NONE) {
            row_of[c] = r;
            col_of[r] = c;
        }
    }
    let mut seen = vec![NONE; n]; // the search that last visited the column
    let mut path: Vec<(usize, usize)> = Vec::new(); // (row, next entry to try)
    for r0 in 0..m {
        if col_of[r0] != NONE {
            continue;
        }
        path.clear();
        path.push((r0, start[r0]));
        let mut found = NONE;
        while let Some(top) = path.last_mut() {
            let (r, p) = *top;
            if p == start[r + 1] {
                path.pop();
                continue;
            }
            top.1 += 1;
            let c = adj[p];
            if seen[c] == r0 {
                continue;
            }
            seen[c] = r0;
            if row_of[c] == NONE {
                found = c;
                break;
            }
            let next = row_of[c];
            path.push((next, start[next]));
        }
        if found == NONE {
            continue;
        }
        // flip the path: each row on it takes the column it reached
        let mut c = found;
        while let Some((r, _)) = path.pop() {
            let old = col_of[r];
            row_of[c] = r;
            col_of[r] = c;
            c = old;
        }
    }
    row_of
}

/// Tarjan's strongly connected components of the graph on n nodes (node v's
/// successors adj[start[v]..start[v + 1]]), each emitted after every one it
/// reaches: in dependency order. Iterative (no recursion depth).
pub fn components(n: usize, start: &[usize], adj: &[usize]) -> Vec<Vec<usize>> {
    let (mut index, mut low, mut on) = (vec![NONE; n], vec![0usize; n], vec![false; n]);
    let (mut stack, mut call, mut out) = (Vec::new(), Vec::<(usize, usize)>::new(), Vec::new());
    let mut next = 0;
    for s in 0..n {
        if index[s] != NONE {
            continue;
        }
        index[s] = next;
        low[s] = next;
        next += 1;
        stack.push(s);
        on[s] = true;
        call.push((s, start[s]));
        while let Some(top) = call.last_mut() {
            let (v, p) = *top;
            if p < start[v + 1] {
                top.1 += 1;
                let w = adj[p];
                if index[w] == NONE {
                    index[w] = next;
                    low[w] = next;
                    next += 1;
                    stack.push(w);
                    on[w] = true;
                    call.push((w, start[w]));
                } else if on[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            call.pop();
            if let Some(&(u, _)) = call.last() {
                low[u] = low[u].min(low[v]);
            }
            if low[v] == index[v] {
                let mut comp = Vec::new();
                while let Some(w) = stack.pop() {
                    on[w] = false;
                    comp.push(w);
                    if w == v {
                        break;
                    }
                }
                comp.sort_unstable();
                out.push(comp);
            }
        }
    }
    out
}

/// The block-triangular decomposition of the m x n pattern with entries
/// (rows[e], cols[e]) (repeats allowed).
pub fn decompose(m: usize, n: usize, rows: &[usize], cols: &[usize]) -> Decomposition {
    let (start, adj) = lists(m, rows.iter().copied().zip(cols.iter().copied()));
    let row_of = matching(m, n, &start, &adj);
    let rank = row_of.iter().filter(|&&r| r != NONE).count();
    let kind = if m > n {
        Kind::Redundant
    } else if m < n {
        Kind::Underdetermined
    } else if rank < n {
        Kind::Singular
    } else {
        Kind::Exact
    };
    if kind != Kind::Exact {
        let whole = Block { rows: (0..m).collect(), cols: (0..n).collect() };
        return Decomposition { blocks: if m + n > 0 { vec![whole] } else { Vec::new() }, kind, rank };
    }
    // coordinate c depends on c' when c's matched row has an entry in c'
    let mut col_of = vec![NONE; m];
    for (c, &r) in row_of.iter().enumerate() {
        col_of[r] = c;
    }
    let (cstart, cadj) = lists(n, rows.iter().zip(cols).map(|(&r, &c)| (col_of[r], c)));
    let blocks = components(n, &cstart, &cadj)
        .into_iter()
        .map(|cols| Block { rows: cols.iter().map(|&c| row_of[c]).collect(), cols })
        .collect();
    Decomposition { blocks, kind, rank }
}

/// The connected components of the pattern's coordinates (two joined when
/// a row has entries in both): a label per coordinate, the components
/// numbered in the order of their smallest coordinate (as
/// scipy.sparse.csgraph.connected_components numbers them).
pub fn connected(m: usize, n: usize, rows: &[usize], cols: &[usize]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    let mut first = vec![NONE; m]; // each row's first coordinate
    for (&r, &c) in rows.iter().zip(cols) {
        if first[r] == NONE {
            first[r] = c;
            continue;
        }
        let (a, b) = (root(&mut parent, first[r]), root(&mut parent, c));
        parent[a.max(b)] = a.min(b);
    }
    let mut label = vec![NONE; n];
    let mut count = 0;
    for c in 0..n {
        let r = root(&mut parent, c);
        if label[r] == NONE {
            label[r] = count;
            count += 1;
        }
        label[c] = label[r];
    }
    label
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn sizes(d: &Decomposition) -> Vec<usize> {
        d.blocks.iter().map(|b| b.cols.len()).collect()
    }

    /// the slider-crank of Sec. 4.4.1 (cases/slider_crank.toml): bodies
    /// ground 0-2, crank 3-5, rod 6-8, slider 9-11; rows: ground (3),
    /// revolute O, B, A (2 each), translational (2), driver (1)
    pub(crate) fn slider_crank() -> (Vec<usize>, Vec<usize>) {
        let mut e: Vec<(usize, usize)> = vec![(0, 0), (1, 1), (2, 2)];
        let mut row = 3;
        for (i, j) in [(1, 0), (2, 1), (3, 2)] {
            // revolute between bodies i and j: x row (xi, phii, xj, phij), y row (yi, phii, yj, phij)
            for k in 0..2 {
                for c in [3 * i + k, 3 * i + 2, 3 * j + k, 3 * j + 2] {
                    e.push((row, c));
                }
                row += 1;
            }
        }
        // translational slider (3) on ground (0): u x d (xi, yi, phii, xj, yj, phij), phi_i - phi_j
        for c in [9, 10, 11, 0, 1, 2] {
            e.push((row, c));
        }
        e.push((row + 1, 11));
        e.push((row + 1, 2));
        e.push((row + 2, 5)); // driver of the crank's phi
        e.into_iter().unzip()
    }

    fn check(m: usize, n: usize, rows: &[usize], cols: &[usize], d: &Decomposition) {
        if d.kind != Kind::Exact {
            assert_eq!(d.blocks.len(), 1);
            return;
        }
        let (mut brow, mut bcol) = (vec![NONE; m], vec![NONE; n]);
        for (k, b) in d.blocks.iter().enumerate() {
            assert_eq!(b.rows.len(), b.cols.len());
            for (&r, &c) in b.rows.iter().zip(&b.cols) {
                assert_eq!((brow[r], bcol[c]), (NONE, NONE), "a row or coordinate in two blocks");
                brow[r] = k;
                bcol[c] = k;
                assert!(rows.iter().zip(cols).any(|(&a, &b)| (a, b) == (r, c)), "matched pair not an entry");
            }
        }
        assert!(brow.iter().chain(&bcol).all(|&b| b != NONE), "every row and coordinate in a block");
        // block lower triangular: an entry's row is in its coordinate's block or a later one
        for (&r, &c) in rows.iter().zip(cols) {
            assert!(brow[r] >= bcol[c], "entry ({r}, {c}) above the block diagonal");
        }
        // irreducible: every block's dependency graph is strongly connected
        for b in &d.blocks {
            let inside = |c: usize| b.cols.contains(&c);
            let reach = |forward: bool| {
                let mut seen = vec![b.cols[0]];
                let mut todo = vec![b.cols[0]];
                while let Some(v) = todo.pop() {
                    for (&r, &c) in rows.iter().zip(cols) {
                        let row_c = b.cols[b.rows.iter().position(|&x| x == r).unwrap_or(0)];
                        if !b.rows.contains(&r) || !inside(c) {
                            continue;
                        }
                        let (from, to) = if forward { (row_c, c) } else { (c, row_c) };
                        if from == v && !seen.contains(&to) {
                            seen.push(to);
                            todo.push(to);
                        }
                    }
                }
                seen.len()
            };
            assert_eq!(reach(true), b.cols.len(), "block {:?} not strongly connected", b.cols);
            assert_eq!(reach(false), b.cols.len(), "block {:?} not strongly connected", b.cols);
        }
    }

    /// the maximum matching's size by brute force (subsets of columns, n <= 10)
    fn brute_rank(m: usize, rows: &[usize], cols: &[usize]) -> usize {
        let mut sets = std::collections::HashSet::from([0u32]);
        for r in 0..m {
            let mine: Vec<usize> = rows.iter().zip(cols).filter(|(&a, _)| a == r).map(|(_, &c)| c).collect();
            let mut next = sets.clone();
            for &s in &sets {
                for &c in &mine {
                    if s >> c & 1 == 0 {
                        next.insert(s | 1 << c);
                    }
                }
            }
            sets = next;
        }
        sets.iter().map(|s| s.count_ones() as usize).max().unwrap_or(0)
    }

    #[test]
    fn the_slider_crank_is_ground_crank_then_its_loop() {
        let (rows, cols) = slider_crank();
        let d = decompose(12, 12, &rows, &cols);
        assert_eq!(d.kind, Kind::Exact);
        check(12, 12, &rows, &cols, &d);
        // ground's three, the crank's phi by its driver, its x and y by O, then rod and slider together
        // (rod x, y, phi and slider x, y: the slider's phi is the translational's angle row, alone)
        assert_eq!(sizes(&d), vec![1, 1, 1, 1, 1, 1, 1, 5]);
        assert_eq!(d.blocks.last().map(|b| b.cols.clone()), Some(vec![6, 7, 8, 9, 10]));
        let first: Vec<usize> = d.blocks[..3].iter().map(|b| b.cols[0]).collect();
        assert_eq!(first, vec![0, 1, 2], "ground first");
    }

    #[test]
    fn a_four_bar_is_one_loop_after_the_crank() {
        // ground 0-2, crank 3-5, coupler 6-8, rocker 9-11; revolutes O2 (crank-ground), A (crank-coupler),
        // B (coupler-rocker), O4 (rocker-ground); driver on the crank's phi
        let mut e: Vec<(usize, usize)> = vec![(0, 0), (1, 1), (2, 2)];
        let mut row = 3;
        for (i, j) in [(1, 0), (1, 2), (2, 3), (3, 0)] {
            for k in 0..2 {
                for c in [3 * i + k, 3 * i + 2, 3 * j + k, 3 * j + 2] {
                    e.push((row, c));
                }
                row += 1;
            }
        }
        e.push((row, 5));
        let (rows, cols): (Vec<usize>, Vec<usize>) = e.into_iter().unzip();
        let d = decompose(12, 12, &rows, &cols);
        check(12, 12, &rows, &cols, &d);
        assert_eq!(sizes(&d), vec![1, 1, 1, 1, 1, 1, 6]);
        assert_eq!(d.blocks[6].cols, vec![6, 7, 8, 9, 10, 11]);
    }

    #[test]
    fn merged_variants_are_connected_components_in_order() {
        // two slider-cranks side by side (the second's rows and coordinates after the first's), and a lone coordinate
        let (rows, cols) = slider_crank();
        let (mut r2, mut c2) = (rows.clone(), cols.clone());
        r2.extend(rows.iter().map(|&r| r + 12));
        c2.extend(cols.iter().map(|&c| c + 12));
        let label = connected(24, 25, &r2, &c2);
        assert_eq!(
            label,
            (0..25)
                .map(|c| if c < 12 {
                    0
                } else if c < 24 {
                    1
                } else {
                    2
                })
                .collect::<Vec<_>>()
        );
        assert_eq!(connected(2, 3, &[0, 0, 1], &[2, 0, 1]), vec![0, 1, 0]);
    }

    #[test]
    fn a_chain_is_all_scalar() {
        // x0 = 0, x_k - x_{k-1} = 0: lower bidiagonal
        let n = 40;
        let (mut rows, mut cols) = (vec![0], vec![0]);
        for k in 1..n {
            rows.extend([k, k]);
            cols.extend([k - 1, k]);
        }
        let d = decompose(n, n, &rows, &cols);
        check(n, n, &rows, &cols, &d);
        assert_eq!(d.blocks.len(), n);
        assert!(d.blocks.iter().enumerate().all(|(k, b)| b.cols == vec![k]), "in chain order");
    }

    #[test]
    fn singular_and_redundant_patterns_stay_one_block() {
        // two rows on the same single coordinate, a third coordinate untouched
        let d = decompose(3, 3, &[0, 1, 2, 2], &[0, 0, 1, 2]);
        assert_eq!((d.kind, d.rank, d.blocks.len()), (Kind::Singular, 2, 1));
        assert_eq!(d.blocks[0].cols, vec![0, 1, 2]);
        let d = decompose(3, 2, &[0, 1, 2], &[0, 1, 1]);
        assert_eq!((d.kind, d.blocks.len()), (Kind::Redundant, 1));
        let d = decompose(1, 2, &[0], &[1]);
        assert_eq!((d.kind, d.blocks.len()), (Kind::Underdetermined, 1));
        assert!(Kind::Singular.message().contains("one block"));
    }

    #[test]
    fn random_patterns_decompose_into_irreducible_triangular_blocks() {
        let mut seed = 11u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as usize
        };
        let mut exact = 0;
        for trial in 0..400 {
            let n = 1 + next() % 10;
            let m = if trial % 5 == 0 { n + next() % 3 } else { n };
            let density = 1 + next() % 4; // entries per row, about
            let (mut rows, mut cols) = (Vec::new(), Vec::new());
            for r in 0..m {
                for _ in 0..density {
                    rows.push(r);
                    cols.push(next() % n);
                }
            }
            let d = decompose(m, n, &rows, &cols);
            assert_eq!(d.rank, brute_rank(m, &rows, &cols), "trial {trial}: the matching is maximum");
            check(m, n, &rows, &cols, &d);
            exact += (d.kind == Kind::Exact) as usize;
        }
        assert!(exact > 50, "{exact} exact patterns of 400: the test covers too few");
    }
}
