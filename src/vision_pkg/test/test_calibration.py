"""Calibration YAML parsing (the standard camera_calibration format)."""
import pytest

from vision_pkg import calibration

GOOD = """
image_width: 640
image_height: 480
camera_name: hand_camera
camera_matrix: {rows: 3, cols: 3, data: [554.3, 0, 319.5, 0, 554.3, 239.5, 0, 0, 1]}
distortion_model: plumb_bob
distortion_coefficients: {rows: 1, cols: 5, data: [-0.1, 0.01, 0, 0, 0]}
rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}
projection_matrix: {rows: 3, cols: 4, data: [554.3, 0, 319.5, 0, 0, 554.3, 239.5, 0, 0, 0, 1, 0]}
"""


def test_parse_good_file(tmp_path):
    path = tmp_path / 'cam.yaml'
    path.write_text(GOOD)
    calib = calibration.load_calibration(str(path))
    assert calib['width'] == 640 and calib['height'] == 480
    assert calib['K'][0] == pytest.approx(554.3)
    assert calib['D'] == [-0.1, 0.01, 0.0, 0.0, 0.0]
    assert len(calib['P']) == 12 and calib['camera_name'] == 'hand_camera'


def test_missing_projection_defaults_from_k():
    text = '\n'.join(line for line in GOOD.splitlines() if 'projection' not in line)
    calib = calibration.parse_calibration(text)
    assert calib['P'][:3] == calib['K'][:3] and calib['P'][3] == 0.0


@pytest.mark.parametrize('text, words', [
    ('image_height: 480\n', 'image_width'),
    ('- 1\n- 2\n', 'mapping'),
    (GOOD.replace('554.3, 0, 319.5, 0, 554.3, 239.5, 0, 0, 1', '1, 2, 3'), '3 values'),
    (GOOD.replace('[554.3, 0, 319.5, 0, 554.3', '[0, 0, 319.5, 0, 554.3'), 'positive fx'),
    ('image_width: [\n', 'does not parse'),
])
def test_bad_files_name_the_problem(text, words):
    with pytest.raises(calibration.CalibrationError) as err:
        calibration.parse_calibration(text)
    assert words in str(err.value)


def test_missing_file_names_the_path(tmp_path):
    with pytest.raises(calibration.CalibrationError) as err:
        calibration.load_calibration(str(tmp_path / 'nope.yaml'))
    assert 'nope.yaml' in str(err.value)


def test_resolve_url():
    assert calibration.resolve_url('') == ''
    assert calibration.resolve_url('file:///a/b.yaml') == '/a/b.yaml'
    assert calibration.resolve_url('package://pkg/config/c.yaml',
                                   lambda name: '/opt/' + name) == '/opt/pkg/config/c.yaml'
    with pytest.raises(calibration.CalibrationError):
        calibration.resolve_url('http://example.org/c.yaml')
    with pytest.raises(calibration.CalibrationError):
        calibration.resolve_url('package://pkg')


def test_default_calibration_fov():
    calib = calibration.default_calibration(640, 480, 1.0471975512)   # 60 deg
    assert calib['K'][0] == pytest.approx(320.0 / 0.57735, rel=1e-4)
    assert calib['K'][2] == pytest.approx(319.5)
