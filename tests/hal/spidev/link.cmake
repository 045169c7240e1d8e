# The spidev tests run the real SpidevBus code against a fake /dev/spidev0.0:
# open/ioctl/close/flock are wrapped at link time (spidev_interposer.cpp), which
# works the same natively and under qemu-user (no LD_PRELOAD needed).
target_link_options(${exe} PRIVATE -Wl,--wrap=open -Wl,--wrap=ioctl -Wl,--wrap=close -Wl,--wrap=flock)
