#!/usr/bin/env bash
# Installs the Debian 12 packages topo_gaussian needs (ROS 1 from Debian, PCL, OpenCV, Eigen, ...).
# Idempotent: installs only what is missing; does nothing (and needs no network) when all is there.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  ros-core-dev catkin python3-catkin-pkg python3-rostest ros-message-generation
  rosbash  # rosrun and roscd: the README's `rosrun topo_gaussian topo ...`
  python3-rosbag  # rosbag record/play: the finger rig's bag played back through the rig (test/ros/finger_rig)
  libroscpp-dev libactionlib-dev libactionlib-msgs-dev libtf2-ros-dev tf2-tools
  rviz xvfb x11-apps imagemagick
  libsensor-msgs-dev libvisualization-msgs-dev libgeometry-msgs-dev
  libpcl-dev libpcl-ros-dev libpcl-conversions-dev libcv-bridge-dev libopencv-dev
  libeigen3-dev libnlopt-cxx-dev libyaml-cpp-dev libgtest-dev nlohmann-json3-dev
  libbullet-dev
  liburdfdom-dev  # inertial.urdf read back by the URDF parser in a test (inference_inertial_files)
  libavformat-dev libavcodec-dev libavutil-dev  # a phone video's rotation metadata in a test (vision_container_rotation)
  calculix-ccx gmsh tetgen  # soft-body peer (bench/peer_world/calculix_peer.h): C3D10 FEM, its mesher
  libsuitesparse-dev libopenblas-dev
  libopenmpi-dev
  clang libclang-rt-14-dev
  python3-numpy python3-sensor-msgs python3-visualization-msgs python3-tf2-msgs
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "[install_deps] all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

echo "[install_deps] installing ${#missing[@]} missing packages: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "[install_deps] not root and no sudo: install as root: ${missing[*]}" >&2; exit 1; }
  SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "[install_deps] done"
