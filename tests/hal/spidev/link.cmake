# The spidev tests run the real SpidevBus code against a fake /dev/spidev0.0:
# open/ioctl/close/flock are wrapped at link time (spidev_interposer.cpp), which
# works the same natively and under qemu-user (no LD_PRELOAD needed).
# open64: what open() is with _FILE_OFFSET_BITS=64 on 32-bit targets.
target_link_options(${exe} PRIVATE -Wl,--wrap=open -Wl,--wrap=open64 -Wl,--wrap=ioctl -Wl,--wrap=close
                    -Wl,--wrap=flock)
