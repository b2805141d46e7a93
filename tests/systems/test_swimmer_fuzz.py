"""Fuzz tests (issue 11) of the swimmer: finite connections or an error naming the field (see tests/_fuzz.py)."""

import numpy as np
from _fuzz import FUZZ, WILD, names_a_field
from hypothesis import given
from hypothesis import strategies as st

from geogait import GeogaitError
from geogait.systems import PurcellSwimmer


@FUZZ
@given(n_links=st.one_of(st.integers(-3, 12), st.sampled_from([10**6, 201])),
       lengths=st.one_of(st.none(), st.lists(WILD, min_size=1, max_size=5)),
       drag=WILD, ratio=WILD, frame=st.sampled_from(["middle", "tail", "center_of_mass", "head"]))
def test_swimmer_is_finite_or_names_the_field(n_links, lengths, drag, ratio, frame):
    try:
        swimmer = PurcellSwimmer(n_links, link_lengths=lengths, drag_coefficient=drag, drag_ratio=ratio,
                                 body_frame=frame)
    except GeogaitError as error:
        assert names_a_field(error), error
        return
    shapes = np.linspace(-1, 1, 3 * swimmer.n_joints).reshape(3, swimmer.n_joints)
    assert np.all(np.isfinite(swimmer.connection(shapes)))
