"""Images: the chessboard, corner detection and camera calibration (OpenCV), and the
dataset folder format (``rasc-dataset/1``)."""
