"""Seam-free gradient-domain fusion of map tiles (issue 14, :mod:`tilesynth.builder.fusion`): the exact DST solve
against a sparse least-squares oracle, the tile border ring kept, no change without a seam, masked pixels never
read, and the cut seam of a smooth map brought down to its patches' own steps."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.linalg import lsqr

from tilesynth.builder.fusion import CLAMP_WIDTH, exemplar_levels, fuse_tiles


def _random_provenance(r, k, n, h, w, pieces=3):
    """Tiles made of ``pieces`` rectangles, each a straight copy of a random exemplar window."""
    src = np.zeros((k, n, n, 2), np.int32)
    yy, xx = np.mgrid[0:n, 0:n]
    for t in range(k):
        cuts = np.sort(r.integers(1, n, pieces - 1))
        band = np.searchsorted(cuts, (yy + xx) // 2, side="right")  # diagonal bands: seams along both axes
        for b in range(pieces):
            oy, ox = r.integers(0, h - n), r.integers(0, w - n)
            sel = band == b
            src[t][sel] = np.stack([yy[sel] + oy, xx[sel] + ox], axis=-1)
    return src


def _oracle(values, copies, src, valid=None, clamp=None):
    """min Σ_edges (f_q − f_p − v_pq)² over the interior, ring fixed, by sparse least squares (scipy). With
    ``clamp`` w, as defined in ``fuse_tiles``' docstring: every interior pixel next to the ring is fixed too, at
    the mean over its edges into the ring of ring value + wanted step (so the correction's slope through the
    border is that of the guidance), and the energy gets w² Σ_interior pixels (divergence of the edge residuals)² (w =
    inf: the divergence term alone); solved densely (numpy lstsq)."""
    k, n, _, c = copies.shape
    h, w = values.shape[:2]
    out = copies.copy()
    idx = -np.ones((n, n), int)
    idx[1:-1, 1:-1] = np.arange((n - 2) ** 2).reshape(n - 2, n - 2)
    for t in range(k):
        for ch in range(c):
            rows, cols, vals, rhs = [], [], [], []
            inc_rows, inc_cols, inc_vals = [], [], []  # pixel x edge incidence (the divergence of residuals)
            pinned = {}  # clamp: interior pixel next to the ring -> its values wanted from each ring edge
            e = 0
            for dy, dx in ((1, 0), (0, 1)):
                for y in range(n - dy):
                    for x in range(n - dx):
                        p, q = (y, x), (y + dy, x + dx)
                        if idx[p] < 0 and idx[q] < 0:
                            continue
                        sp, sq = src[t][p], src[t][q]
                        if sq[0] == sp[0] + dy and sq[1] == sp[1] + dx:
                            v = values[sq[0], sq[1], ch] - values[sp[0], sp[1], ch]
                        else:
                            steps = []
                            a = (sp[0] + dy, sp[1] + dx)
                            if a[0] < h and a[1] < w and (valid is None or valid[a]):
                                steps.append(values[a[0], a[1], ch] - values[sp[0], sp[1], ch])
                            b = (sq[0] - dy, sq[1] - dx)
                            if b[0] >= 0 and b[1] >= 0 and (valid is None or valid[b]):
                                steps.append(values[sq[0], sq[1], ch] - values[b[0], b[1], ch])
                            v = float(np.mean(steps)) if steps else 0.0
                        b_e = v
                        if (idx[p] < 0) != (idx[q] < 0):  # an edge into the ring: fixes its interior end
                            inner, ring_v = (
                                (q, copies[t][p][ch] + v) if idx[p] < 0 else (p, copies[t][q][ch] - v)
                            )
                            pinned.setdefault(idx[inner], []).append(ring_v)
                        for pix, sign in ((q, 1.0), (p, -1.0)):
                            if idx[pix] >= 0:
                                rows.append(e)
                                cols.append(idx[pix])
                                vals.append(sign)
                            else:
                                b_e -= sign * copies[t][pix][ch]
                        rhs.append(b_e)
                        inc_rows += [q[0] * n + q[1], p[0] * n + p[1]]
                        inc_cols += [e, e]
                        inc_vals += [1.0, -1.0]
                        e += 1
            a_mat = coo_matrix((vals, (rows, cols)), shape=(e, (n - 2) ** 2)).tocsr()
            if clamp is None:
                sol = lsqr(a_mat, np.array(rhs), atol=1e-14, btol=1e-14, iter_lim=20000)[0]
            else:
                inc = coo_matrix((inc_vals, (inc_rows, inc_cols)), shape=(n * n, e)).toarray()
                inc = inc[(idx >= 0).reshape(-1)]  # the divergence at the interior pixels
                dense, r = a_mat.toarray(), np.array(rhs)
                if np.isinf(clamp):
                    big, big_r = inc @ dense, inc @ r
                else:
                    big = np.vstack([dense, clamp * (inc @ dense)])
                    big_r = np.concatenate([r, clamp * (inc @ r)])
                fixed = np.zeros((n - 2) ** 2, bool)
                value = np.zeros((n - 2) ** 2)
                near = np.zeros((n, n), bool)
                near[1:-1, 1:-1] = True
                near[2:-2, 2:-2] = False
                for y, x in zip(*np.nonzero(near)):
                    for dy, dx in ((1, 0), (0, 1), (-1, 0), (0, -1)):  # a seam along the ring frees the pixel
                        yy, xx = y + dy, x + dx
                        if near[yy, xx]:
                            sp, sq = src[t][y, x], src[t][yy, xx]
                            if sq[0] != sp[0] + dy or sq[1] != sp[1] + dx:
                                pinned.pop(idx[y, x], None)
                for j, wanted in pinned.items():
                    fixed[j], value[j] = True, float(np.mean(wanted))
                free = np.linalg.lstsq(big[:, ~fixed], big_r - big[:, fixed] @ value[fixed], rcond=None)[0]
                sol = value.copy()
                sol[~fixed] = free
            out[t, 1:-1, 1:-1, ch] = sol.reshape(n - 2, n - 2)
    return out


@pytest.mark.parametrize(
    ("seed", "clamp"), [(0, None), (1, None), (2, None), (0, 4.0), (1, 1.5), (2, CLAMP_WIDTH), (3, np.inf)]
)
def test_matches_the_least_squares_oracle_and_keeps_the_ring(seed, clamp):
    r = np.random.default_rng(seed)
    h = w = 30
    values = r.random((h, w, 2))
    src = _random_provenance(r, 3, 9, h, w)
    copies = values[src[..., 0], src[..., 1]]
    valid = r.random((h, w)) > 0.2 if seed == 2 else None
    fused = fuse_tiles(values, copies, src, valid, clamp=clamp)
    ref = _oracle(values, copies, src, valid, clamp=clamp)
    np.testing.assert_allclose(fused, ref, atol=1e-8)
    ring = np.ones((9, 9), bool)
    ring[1:-1, 1:-1] = False
    assert np.array_equal(fused[:, ring], copies[:, ring])


def test_no_seam_no_change():
    r = np.random.default_rng(4)
    values = r.random((20, 20, 1))
    yy, xx = np.mgrid[0:8, 0:8]
    src = np.stack([yy + 3, xx + 5], axis=-1)[None].astype(np.int32)
    copies = values[src[..., 0], src[..., 1]]
    np.testing.assert_allclose(fuse_tiles(values, copies, src), copies, atol=1e-12)
    tiny = copies[:, :2, :2]
    assert np.array_equal(fuse_tiles(values, tiny, src[:, :2, :2]), tiny)  # no interior


def test_an_invalid_pixel_is_never_read():
    r = np.random.default_rng(5)
    values = r.random((30, 30, 1))
    src = _random_provenance(r, 2, 10, 30, 30)
    copies = values[src[..., 0], src[..., 1]]
    used = np.zeros((30, 30), bool)
    used[src[..., 0], src[..., 1]] = True
    a = fuse_tiles(values, copies, src, used)
    changed = values.copy()
    changed[~used] = 1e6  # pixels the set never uses (masked ones among them)
    assert np.array_equal(a, fuse_tiles(changed, copies, src, used))
    assert not np.array_equal(a, fuse_tiles(changed, copies, src, None))  # the test can fail


def test_a_level_offset_between_patches_is_spread_not_a_cliff():
    """A smooth ramp map whose two patches differ by a level offset: the copies show a cliff along the seam, the
    fused tile's steps across the seam are about the ramp's own step away from the border ring (which keeps the
    copies, cliff included, and so takes the offset back within a few pixels)."""
    yy, xx = np.mgrid[0:64, 0:64]
    values = (0.01 * xx + 0.002 * yy)[..., None].astype(np.float64)
    n = 24
    ty, tx = np.mgrid[0:n, 0:n]
    left = tx < n // 2
    src = np.where(left[..., None], np.stack([ty + 2, tx + 3], -1), np.stack([ty + 30, tx + 20], -1))[None]
    copies = values[src[..., 0], src[..., 1]]
    fused = fuse_tiles(values, copies, src.astype(np.int32))
    across_copy = np.abs(np.diff(copies[0, 1:-1, :, 0], axis=1)[:, n // 2 - 1])
    across_fused = np.abs(np.diff(fused[0, 1:-1, :, 0], axis=1)[:, n // 2 - 1])
    assert across_copy.min() > 0.15  # the cliff (offset 17 columns x 0.01 + 28 rows x 0.002)
    assert across_fused.max() < across_copy.min()
    assert across_fused[4:-4].max() < 0.03  # the ramp's own 0.01 per column plus the spread offset


def _two_patch_set(n: int = 24):
    """A smooth ramp exemplar and one tile of two patches with a level offset (as in the test above)."""
    yy, xx = np.mgrid[0:64, 0:64]
    values = (0.01 * xx + 0.002 * yy)[..., None].astype(np.float64)
    ty, tx = np.mgrid[0:n, 0:n]
    left = tx < n // 2
    src = np.where(left[..., None], np.stack([ty + 2, tx + 3], -1), np.stack([ty + 30, tx + 20], -1))[None]
    return values, src.astype(np.int32)


def test_exemplar_levels_take_the_offset_the_ring_cannot():
    """The exemplar's level correction moves both patches (their border rings too), so the cliff goes right up
    to the ring, where the tile-interior fusion alone keeps it."""
    values, src = _two_patch_set()
    copies = values[src[..., 0], src[..., 1]]
    phi = exemplar_levels(values, copies, src)
    assert phi.shape == values.shape
    f = values + phi
    levelled = f[src[..., 0], src[..., 1]]
    n = src.shape[1]
    across = np.abs(np.diff(levelled[0, :, :, 0], axis=1)[:, n // 2 - 1])
    plain = np.abs(np.diff(fuse_tiles(values, copies, src)[0, :, :, 0], axis=1)[:, n // 2 - 1])
    assert across.max() < 0.05 < plain.max()  # the ring rows too (offset 0.23 as copied)
    assert np.array_equal(phi, exemplar_levels(values, copies, src))  # deterministic
    assert abs(float(phi[src[..., 0], src[..., 1]].mean())) < 0.01  # about the mean level kept (offset 0.23)


def test_exemplar_levels_are_zero_without_seams_and_check_the_block():
    r = np.random.default_rng(6)
    values = r.random((20, 20, 2))
    yy, xx = np.mgrid[0:8, 0:8]
    src = np.stack([yy + 3, xx + 5], axis=-1)[None].astype(np.int32)
    copies = values[src[..., 0], src[..., 1]]
    np.testing.assert_allclose(exemplar_levels(values, copies, src), 0.0, atol=1e-12)
    with pytest.raises(ValueError, match="block"):
        exemplar_levels(values, copies, src, block=0)


def test_exemplar_levels_keep_tilings_seamless():
    """Two tiles that continue one exemplar strip across their shared border (a tiling's border pair) keep
    exemplar-neighbour pairs there, so after the correction the step across the border is the corrected
    exemplar's own step, whatever seams the tile interiors have."""
    r = np.random.default_rng(7)
    values = r.random((40, 40, 1))
    n = 10
    ty, tx = np.mgrid[0:n, 0:n]
    a = np.stack([ty + 5, tx + 5], -1)
    b = np.stack([ty + 5, tx + 5 + n], -1)  # b continues a to the right
    b[3:7, 3:7] = np.stack([ty[3:7, 3:7] + 25, tx[3:7, 3:7] + 25], -1)  # an inner patch from elsewhere
    src = np.stack([a, b]).astype(np.int32)
    copies = values[src[..., 0], src[..., 1]]
    f = values + exemplar_levels(values, copies, src)
    out = fuse_tiles(f, f[src[..., 0], src[..., 1]], src)
    np.testing.assert_allclose(
        out[1, :, 0] - out[0, :, -1], f[5 : 5 + n, 5 + n] - f[5 : 5 + n, 4 + n], atol=1e-12
    )


def _diagonal_set(n=16, h=48, w=48):
    """One tile cut along its main diagonal (a Wang cut ending at two tile corners): the lower-left triangle from
    one exemplar window, the rest from another with a level offset of 0.3; a smooth exemplar."""
    yy, xx = np.mgrid[0:h, 0:w]
    values = (0.004 * xx + 0.003 * yy)[..., None].astype(np.float64)
    values[20:, 20:] += 0.3
    ty, tx = np.mgrid[0:n, 0:n]
    lower = ty > tx
    src = np.where(lower[..., None], np.stack([ty + 1, tx + 1], -1), np.stack([ty + 24, tx + 24], -1))[None]
    return values, src.astype(np.int32)


def test_exemplar_levels_give_the_corner_pixels_their_own_level():
    """Where a cut ends at a tile corner, the ring pixels there are fixed for the tile-interior fusion and a 4-px
    block field takes only their mean offset; with their own level (``corner``) the ring steps across the cut
    near the corners fall. Without a seam near a corner (ω's tiles) nothing changes, bit for bit."""
    from tilesynth.builder.fusion import LEVEL_CORNER, _corner_pixels

    values, src = _diagonal_set()
    n = src.shape[1]
    assert LEVEL_CORNER == 2
    own = _corner_pixels(src, 2, values.shape[1])
    assert own.size > 0 and set(own.tolist()) >= {int(src[0, 0, 0, 0]) * 48 + int(src[0, 0, 0, 1])}
    copies = values[src[..., 0], src[..., 1]]

    def ring_steps(corner):
        f = values + exemplar_levels(values, copies, src, corner=corner)
        t = fuse_tiles(f, f[src[..., 0], src[..., 1]], src)[0, ..., 0]
        # the cut pairs on the ring within 2 px of the corners (0, 0) and (n - 1, n - 1)
        pairs = [
            (t[1, 0], t[0, 0]),
            (t[2, 1], t[2, 2]),
            (t[n - 1, n - 2], t[n - 1, n - 1]),
            (t[1, 0], t[1, 1]),
        ]
        return max(abs(a - b) for a, b in pairs)

    assert ring_steps(LEVEL_CORNER) < 0.5 * ring_steps(0)
    phi = exemplar_levels(values, copies, src)
    assert np.array_equal(phi, exemplar_levels(values, copies, src))  # deterministic
    # a tile whose seam does not come near a corner (the two halves of _two_patch_set): no own pixels, same bytes
    values2, src2 = _two_patch_set()
    assert _corner_pixels(src2, 2, values2.shape[1]).size == 0
    copies2 = values2[src2[..., 0], src2[..., 1]]
    assert np.array_equal(
        exemplar_levels(values2, copies2, src2), exemplar_levels(values2, copies2, src2, corner=0)
    )
    with pytest.raises(ValueError, match="corner"):
        exemplar_levels(values2, copies2, src2, corner=-1)
