"""The executor keeps input order and gives the same result for any worker count."""

from sgpipe.parallel import chunk_ranges, map_chunks


def _square_sum(r):
    a, b = r
    return sum(i * i for i in range(a, b))


def test_map_chunks_order_and_worker_independence():
    chunks = chunk_ranges(1000, 37)
    assert chunks[0] == (0, 37) and chunks[-1] == (999, 1000) and len(chunks) == 28
    serial = map_chunks(_square_sum, chunks, workers=1)
    pooled = map_chunks(_square_sum, chunks, workers=2)
    assert serial == pooled
    assert sum(serial) == sum(i * i for i in range(1000))
