#!/bin/bash
# How the GPU frame rates in docs/benchmarks.md were measured (device machine, Ubuntu host without
# X). Expects a Debian 12 bundle unpacked at /opt/glb/bundle: bin/ (Xvfb, xkbcomp, glxinfo, sinew,
# sinew-make-scene), lib/ (every library `ldd` lists for them, libGLX_mesa and its dependencies),
# dri/swrast_dri.so (the server's GLX), xkb/ (xkb-data), plugins/ (Qt's xcb platform and
# xcb-glx integration), fonts/ and data/ (mricron-data's aal, ch2, ch2better). The client renders
# with NVIDIA's GLX; Mesa only serves Xvfb's GLX extension. Variables: LEVELS, BUDGETS, DRAWINGS,
# SIZES (WxH), PARITY=1 to run tst_cuda_parity first.
set -u
B=/opt/glb/bundle
ls $B/lib/libLLVM-15.so.1 >/dev/null || { echo "part A missing (machine restarted?)"; exit 9; }
[ -f .device/partB.tar.xz ] && tar -xJf .device/partB.tar.xz -C /opt/glb  # second half, when carried in two
mkdir -p /usr/share/X11 /usr/lib/x86_64-linux-gnu/dri
echo "dri dir before:"; ls -la /usr/lib/x86_64-linux-gnu/dri | head
ln -sfn $B/xkb /usr/share/X11/xkb
cp -f $B/bin/xkbcomp /usr/bin/xkbcomp
cp -f $B/dri/swrast_dri.so /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so
ls /usr/local/nvidia/lib64 | grep -i -E "glx|egl" | head
ls /usr/share/glvnd/egl_vendor.d /usr/local/nvidia/share/glvnd 2>&1 | head
mkdir -p /tmp/fonts && cp $B/fonts/*.ttf /tmp/fonts/
printf '<?xml version="1.0"?><fontconfig><dir>/tmp/fonts</dir><cachedir>/tmp/fccache</cachedir></fontconfig>\n' > /tmp/fonts.conf
export FONTCONFIG_FILE=/tmp/fonts.conf
export QT_QPA_FONTDIR=/tmp/fonts QT_PLUGIN_PATH=$B/plugins XDG_RUNTIME_DIR=/tmp/xdg
mkdir -p $XDG_RUNTIME_DIR && chmod 700 $XDG_RUNTIME_DIR
LD_LIBRARY_PATH=$B/lib $B/bin/Xvfb :7 -screen 0 1600x1000x24 +extension GLX -nolisten tcp > /tmp/xvfb.out 2>&1 &
XPID=$!
sleep 4
echo "== xvfb log"; cat /tmp/xvfb.out | head -30
export LD_LIBRARY_PATH=$B/lib:/usr/local/nvidia/lib64
export DISPLAY=:7
echo "== glxinfo mesa"; __GLX_VENDOR_LIBRARY_NAME=mesa $B/bin/glxinfo -B 2>&1 | head -20
echo "== glxinfo nvidia"; __GLX_VENDOR_LIBRARY_NAME=nvidia $B/bin/glxinfo -B 2>&1 | head -20
export __GLX_VENDOR_LIBRARY_NAME=nvidia QT_XCB_GL_INTEGRATION=xcb_glx
cd /tmp
D=$B/data
[ -f /tmp/big.json ] || $B/bin/sinew-make-scene --atlas $D/aal.nii.gz --labels $D/aal.nii.txt --training $D/ch2.nii.gz --target $D/ch2better.nii.gz \
  --iterations 20,10,10,10,10,10 -o /tmp/big.json | tail -1
mkdir -p $OUT
[ -n "${PARITY:-}" ] && { LD_LIBRARY_PATH=$B/lib:/usr/local/nvidia/lib64 QT_QPA_PLATFORM=offscreen $B/bin/tst_cuda_parity 2>&1 | tail -15; }
for lv in ${LEVELS:-4 5}; do
 for bm in ${BUDGETS:-30}; do
  for dr in ${DRAWINGS:-interop host}; do
   for sz in ${SIZES:-1400x900}; do
    echo "== level $lv budget $bm drawing $dr window $sz"
    timeout 200 $B/bin/sinew /tmp/big.json --backend cuda --drawing $dr --measure-fps 5 --level $lv --budget-ms $bm \
      --window-size ${sz%x*} ${sz#*x} --screenshot $OUT/shot-$lv-$bm-$dr-$sz.png 2>&1 | grep frames_per
   done
  done
 done
done
kill $XPID
