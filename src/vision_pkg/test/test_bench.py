"""bench_detection's real-photo half on a folder the test makes: the label loader's errors, the
photometric variants, and the figures of run_photos (with --photo-variants and --photo-widths)."""
import argparse

import cv2
import numpy as np
import pytest

import synthetic_scene as scene
from vision_pkg import bench
from vision_pkg.bench_photos import PHOTO_VARIANTS, LabelError, load_labels, photo_variant


def _write(path, text):
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize('text, field', [
    ('photos: [a, b]\n', 'photos: missing or not a mapping'),
    ('photos:\n  a.jpg: {fruits: 3}\n', 'photos.a.jpg.fruits'),
    ('photos:\n  a.jpg:\n    fruits:\n      - {u: 1, v: 2, stage: red}\n', 'fruits[0]'),
    ('photos:\n  a.jpg:\n    fruits:\n      - {u: 1, v: 2, r: .nan, stage: red}\n', 'r > 0'),
    ('photos:\n  a.jpg:\n    fruits:\n      - {u: 1, v: 2, r: 3, stage: ripe}\n',
     "'ripe' is not one of"),
    ('photos: {a.jpg: {fruits: [}\n', 'a.yaml')])
def test_a_malformed_label_file_names_the_field(tmp_path, text, field):
    with pytest.raises(LabelError) as info:
        load_labels(_write(tmp_path / 'a.yaml', text))
    assert field in str(info.value)


def test_photo_variants_keep_the_image_size_and_type():
    image = np.random.default_rng(0).integers(0, 256, (60, 80, 3), dtype=np.uint8)
    assert photo_variant(image, 'none', None) is image
    for name, (kind, value) in PHOTO_VARIANTS:
        out = photo_variant(image, kind, value)
        assert out.shape == image.shape and out.dtype == np.uint8, name
    grey = np.full((10, 10, 3), 100, np.uint8)
    warm = photo_variant(grey, 'gains', (0.75, 0.95, 1.2))[0, 0]
    assert warm[2] > warm[1] > warm[0]                        # BGR: red up, blue down
    assert photo_variant(grey, 'exposure', 0.6)[0, 0, 0] == 60
    assert photo_variant(grey, 'gamma', 1.25)[0, 0, 0] < 100  # darker mid-tones
    with pytest.raises(ValueError):
        photo_variant(grey, 'sepia', 1.0)


def test_run_photos_counts_the_labelled_fruit_and_runs_every_variant(tmp_path):
    # two "photos" of red and green fruit, labelled at their true circles; one red fruit
    # labelled pink (a grading disagreement: a false positive), and one label with no fruit
    # (a miss)
    fruits = [scene.Fruit(-0.06, 0.0, 0.5, 0.035, 0.95), scene.Fruit(0.07, 0.02, 0.5, 0.035, 0.95),
              scene.Fruit(0.0, -0.12, 0.55, 0.035, 0.05)]
    image, _, _ = scene.render(fruits, backdrop_depth=0.95)
    cv2.imwrite(str(tmp_path / 'one.jpg'), image, [cv2.IMWRITE_JPEG_QUALITY, 95])
    cv2.imwrite(str(tmp_path / 'two.jpg'), image, [cv2.IMWRITE_JPEG_QUALITY, 95])
    scale = 1024.0 / image.shape[1]

    def label(fruit, stage):
        x0, y0, x1, y1 = scene.gt_box(fruit)
        return '      - {u: %.1f, v: %.1f, r: %.1f, stage: %s}\n' % (
            (x0 + x1) / 2.0 / scale, (y0 + y1) / 2.0 / scale, (x1 - x0) / 2.0 / scale, stage)
    one = label(fruits[0], 'red') + label(fruits[1], 'red') + label(fruits[2], 'green')
    two = label(fruits[0], 'red') + label(fruits[1], 'pink') + label(fruits[2], 'green') + \
        '      - {u: 20, v: 20, r: 15, stage: red}\n'
    labels = _write(tmp_path / 'labels.yaml', 'photos:\n  one.jpg:\n    fruits:\n' + one +
                    '  two.jpg:\n    fruits:\n' + two)
    lines = []
    args = argparse.Namespace(photos=str(tmp_path), labels=labels, config=None, min_ripeness=0.7,
                              min_visible=0.5, photo_width=1024, repeat=1, save_dir=None,
                              verbose=False, photo_variants=True)
    figures = bench.run_photos(args, log=lines.append)
    # the 15 px label at the corner is below min_radius_px at 1024 wide: "don't care"
    assert (figures['tp'], figures['fp'], figures['fn']) == (3, 1, 0), lines
    assert figures['stage_accuracy'] == pytest.approx(5.0 / 6.0)
    assert list(figures['variants']) == [name for name, _ in PHOTO_VARIANTS]
    as_taken = figures['variants']['as taken']
    assert (as_taken['tp'], as_taken['fp'], as_taken['fn']) == (3, 1, 0)
    assert any(line.startswith('  ripe F1 over the %d variants' % len(PHOTO_VARIANTS))
               for line in lines), lines
    # with --min-care-radius 10 the 15 px label counts: a miss
    args.min_care_radius, args.photo_variants = 10.0, False
    figures = bench.run_photos(args, log=lines.append)
    assert (figures['tp'], figures['fp'], figures['fn']) == (3, 1, 1), lines
    # --photo-widths: at 1024 wide the figures of the photos as taken; at half that width the
    # fruit are half as large in pixels, still above min_radius_px, and found again
    args.min_care_radius, args.photo_widths = None, [1024, 512]
    lines = []
    widths = bench.run_photos(args, log=lines.append)['widths']
    assert sorted(widths) == [512, 1024]
    for width in (1024, 512):
        got = widths[width]
        assert (got['tp'], got['fp'], got['fn']) == (3, 1, 0), (width, lines)
    assert any(line.startswith('  ripe F1 over the 2 widths') for line in lines), lines


def test_photo_widths_are_read_as_a_list_of_pixels():
    assert bench._widths('640, 768,1024') == [640, 768, 1024]
    for bad in ('6x', '', '32'):
        with pytest.raises(argparse.ArgumentTypeError):
            bench._widths(bad)


def test_run_photos_without_a_folder_says_so():
    lines = []
    args = argparse.Namespace(photos='/nonexistent/photos', labels=None)
    assert bench.run_photos(args, log=lines.append) is None
    assert 'skipped' in lines[0]
