//! Work spread over every core with scoped threads: the verifications of
//! `pipeline` and the ZNCC queries of `matching`. Results come back in the
//! items' order, so the output does not depend on the number of cores.

/// `f` over `items` on every available core, `None`s dropped.
pub fn map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> Option<R> + Sync) -> Vec<R> {
    map_with(items, || (), |_, item| f(item))
}

/// As [`map`], with one `state` per thread made by `init` (buffers that a
/// single call of `f` must not share with another thread).
pub fn map_with<T: Sync, R: Send, S>(
    items: &[T],
    init: impl Fn() -> S + Sync,
    f: impl Fn(&mut S, &T) -> Option<R> + Sync,
) -> Vec<R> {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(items.len().max(1));
    if threads <= 1 {
        let mut state = init();
        return items
            .iter()
            .filter_map(|item| f(&mut state, item))
            .collect();
    }
    let chunk = items.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .chunks(chunk)
            .map(|part| {
                scope.spawn(|| {
                    let mut state = init();
                    part.iter()
                        .filter_map(|item| f(&mut state, item))
                        .collect::<Vec<R>>()
                })
            })
            .collect();
        // A worker that panicked takes its chunk's results with it: raise
        // its panic here rather than return the others as if complete.
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_keep_the_items_order_and_drop_nones() {
        let items: Vec<u32> = (0..1000).collect();
        let out = map_with(
            &items,
            || 0u32,
            |calls, &x| {
                *calls += 1;
                (x % 3 != 0).then_some(x * 2)
            },
        );
        let expected: Vec<u32> = items
            .iter()
            .filter(|&&x| x % 3 != 0)
            .map(|x| x * 2)
            .collect();
        assert_eq!(out, expected);
        assert!(map(&[] as &[u32], |&x| Some(x)).is_empty());
    }
}
