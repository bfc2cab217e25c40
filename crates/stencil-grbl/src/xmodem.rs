//! XModem and YModem, the file transfers grblHAL (YModem) and FluidNC (XModem) take over the
//! same stream as G-code: the control bytes, the CRC-16 every packet carries, and packets as
//! they go on the wire. Shared by the sender and the virtual board's card.

/// Start of a 128-byte packet.
pub(crate) const SOH: u8 = 0x01;
/// Start of a 1024-byte packet.
pub(crate) const STX: u8 = 0x02;
/// End of the file.
pub(crate) const EOT: u8 = 0x04;
/// The packet arrived whole.
pub(crate) const ACK: u8 = 0x06;
/// The packet was damaged: send it again.
pub(crate) const NAK: u8 = 0x15;
/// The transfer is cancelled (sent twice).
pub(crate) const CAN: u8 = 0x18;
/// The receiver's request to start, in CRC mode.
pub(crate) const CRC_MODE: u8 = b'C';

/// CRC-16/XMODEM (CCITT polynomial 0x1021, starting at 0), as both protocols check packets.
pub(crate) fn crc16(data: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &b in data {
        crc ^= (b as u16) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// One packet: STX (1024 bytes) or SOH (128), its number and that number's complement, the
/// payload padded with `pad`, and the CRC (high byte first).
pub(crate) fn packet(number: u8, payload: &[u8], pad: u8) -> Vec<u8> {
    let len = if payload.len() <= 128 { 128 } else { 1024 };
    let mut body = payload.to_vec();
    body.resize(len, pad);
    let mut p = vec![if len == 128 { SOH } else { STX }, number, !number];
    let crc = crc16(&body);
    p.extend_from_slice(&body);
    p.extend_from_slice(&crc.to_be_bytes());
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_crc_is_xmodems() {
        // The check value every CRC-16/XMODEM implementation gives for "123456789".
        assert_eq!(crc16(b"123456789"), 0x31C3);
    }

    #[test]
    fn a_packet_is_framed_numbered_padded_and_checked() {
        let p = packet(3, b"G0X1\n", 0x1A);
        assert_eq!((p[0], p[1], p[2], p.len()), (SOH, 3, 0xFC, 3 + 128 + 2));
        assert_eq!(p[3 + 5], 0x1A);
        let crc = u16::from_be_bytes([p[131], p[132]]);
        assert_eq!(crc, crc16(&p[3..131]));
        assert_eq!(packet(1, &[b'x'; 129], 0)[0], STX);
    }
}
