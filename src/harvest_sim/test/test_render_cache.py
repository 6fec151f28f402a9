"""The renderer's disk cache of baked background textures (render_cache): a cached start gives
the very textures a fresh bake gives, a scenario with other light gets its own entry, a broken
entry is baked again and replaced, and `HARVEST_SIM_CACHE=` turns the cache off."""

import os

import numpy as np
import pytest

from sim_fixtures import single_fruit_scenario

from harvest_sim import render, render_cache


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv(render_cache.ENV, str(tmp_path))
    return tmp_path


def entries(directory):
    return sorted(p for p in os.listdir(str(directory)) if p.endswith('.npz'))


def fresh_atlas(scenario, monkeypatch):
    with monkeypatch.context() as m:
        m.setenv(render_cache.ENV, '')
        return render.Renderer(scenario).atlas


def test_cached_start_gives_the_fresh_bake(cache, monkeypatch):
    scenario = single_fruit_scenario((0.5, 0.0, 1.0))
    first = render.Renderer(scenario)
    assert len(entries(cache)) == 1
    stamp = os.path.getmtime(os.path.join(str(cache), entries(cache)[0]))
    second = render.Renderer(scenario)
    assert np.array_equal(second.atlas, first.atlas)
    assert second._atlas_slots == first._atlas_slots and second._sky == first._sky
    assert np.array_equal(second.atlas, fresh_atlas(scenario, monkeypatch))
    # the second start loaded the entry, it did not write it again
    assert os.path.getmtime(os.path.join(str(cache), entries(cache)[0])) == stamp


def test_other_light_is_another_entry(cache):
    scenario = single_fruit_scenario((0.5, 0.0, 1.0))
    base = render.Renderer(scenario).atlas
    scenario.lighting.intensity *= 0.5
    dim = render.Renderer(scenario).atlas
    assert len(entries(cache)) == 2
    assert dim.mean() < base.mean()


def test_broken_entry_is_baked_again_and_replaced(cache, monkeypatch):
    scenario = single_fruit_scenario((0.5, 0.0, 1.0))
    good = render.Renderer(scenario).atlas
    name = os.path.join(str(cache), entries(cache)[0])
    with open(name, 'r+b') as f:             # a file cut short (a full disk, a killed writer)
        f.truncate(1000)
    assert np.array_equal(render.Renderer(scenario).atlas, good)
    assert os.path.getsize(name) > 1000
    assert render_cache.load(entries(cache)[0][:-4], ('canopy', 'aisle', 'floor', 'roof'))
    assert [p for p in os.listdir(str(cache)) if p.endswith('.tmp')] == []


def test_empty_variable_turns_the_cache_off(tmp_path, monkeypatch):
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path))
    monkeypatch.setenv(render_cache.ENV, '')
    assert render_cache.cache_dir() is None
    assert render_cache.store('k', {'a': np.zeros(3)}) is False
    assert render_cache.load('k', ('a',)) is None
    assert os.listdir(str(tmp_path)) == []
    monkeypatch.delenv(render_cache.ENV)
    assert render_cache.cache_dir() == os.path.join(str(tmp_path), 'harvest_sim')


def test_unwritable_directory_only_costs_the_time(tmp_path, monkeypatch):
    blocker = tmp_path / 'file'
    blocker.write_text('not a directory')
    monkeypatch.setenv(render_cache.ENV, str(blocker / 'cache'))
    assert render_cache.store('k', {'a': np.zeros(3)}) is False
    assert render_cache.load('k', ('a',)) is None


def test_oldest_entries_go_beyond_the_limit(cache, monkeypatch):
    monkeypatch.setattr(render_cache, 'MAX_ENTRIES', 3)
    for i in range(5):
        assert render_cache.store('k%d' % i, {'a': np.full(2, i)})
        os.utime(os.path.join(str(cache), 'k%d.npz' % i), (1000 + i, 1000 + i))
    assert entries(cache) == ['k2.npz', 'k3.npz', 'k4.npz']
    assert render_cache.load('k4', ('a',))[0].tolist() == [4, 4]


def test_unreadable_painting_code_means_no_cache(cache, monkeypatch):
    monkeypatch.setattr(render_cache, '_code_digest', '')      # the sources could not be read
    assert render_cache.entry_key('atlas', 1) is None
    assert render_cache.store(None, {'a': np.zeros(3)}) is False
    assert render_cache.load(None, ('a',)) is None
    render.Renderer(single_fruit_scenario((0.5, 0.0, 1.0)))
    assert entries(cache) == []
