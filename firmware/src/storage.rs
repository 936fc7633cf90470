//! Settings that survive a reset: the operator's [`DeviceSettings`] in a
//! `sequential-storage` map (wear-levelled, power-fail safe, erases a page only when the
//! other is full) over the board's flash. The record is a protocol frame
//! ([`estimator_core::protocol::encode`]): version byte and CRC-16 included, so a record
//! of another firmware's format or a corrupted one is refused and the defaults are used.
//!
//! The boards' flash is blocking (stm32f4xx-hal's `embedded-storage` implementation) and
//! sequential-storage is `async`: [`Blocking`] wraps the one as the other, and every
//! future it yields is ready at its first poll, so [`run`] polls exactly once.
//!
//! While the STM32F4 erases or programs its single flash bank, every fetch from flash
//! stalls: the caller stretches the watchdog first, and the sample task counts the
//! periods it could not run as lost (see `board::timers::PeriodClock`).

use core::future::Future;
use core::ops::Range;
use core::pin::pin;
use core::task::{Context, Poll, Waker};

use embedded_storage::nor_flash as blocking;
use embedded_storage_async::nor_flash as nonblocking;
use estimator_core::protocol::{decode, encode, DeviceSettings, MAX_FRAME_BYTES};
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};

/// Key of the settings record.
const SETTINGS_KEY: u8 = 1;
/// Work buffer of the map: key, record and word alignment.
const BUFFER_BYTES: usize = MAX_FRAME_BYTES + 16;

/// A blocking NOR flash seen as an `async` one.
pub struct Blocking<F>(F);

impl<F: blocking::ErrorType> nonblocking::ErrorType for Blocking<F> {
    type Error = F::Error;
}

impl<F: blocking::ReadNorFlash> nonblocking::ReadNorFlash for Blocking<F> {
    const READ_SIZE: usize = F::READ_SIZE;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.0.read(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.0.capacity()
    }
}

impl<F: blocking::NorFlash> nonblocking::NorFlash for Blocking<F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        self.0.erase(from, to)
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.0.write(offset, bytes)
    }
}

impl<F: blocking::MultiwriteNorFlash> nonblocking::MultiwriteNorFlash for Blocking<F> {}

/// Polls `future` once: `None` if it was not ready (never, with [`Blocking`] flash).
fn run<T>(future: impl Future<Output = T>) -> Option<T> {
    let mut future = pin!(future);
    match future
        .as_mut()
        .poll(&mut Context::from_waker(Waker::noop()))
    {
        Poll::Ready(value) => Some(value),
        Poll::Pending => None,
    }
}

/// The map over `F`, without a RAM cache (the settings are read once and written
/// rarely: scanning two pages is fast enough).
type Map<F> = MapStorage<u8, Blocking<F>, Cache<Uncached, Uncached, Uncached, u8>>;

/// The settings record in `range` of a flash `F`.
pub struct SettingsStore<F: blocking::NorFlash> {
    map: Option<Map<F>>,
}

impl<F: blocking::NorFlash + blocking::MultiwriteNorFlash> SettingsStore<F> {
    /// The store; `None`-like (every load and save fails) if `range` is not two or more
    /// whole erase pages.
    pub fn new(flash: F, range: Range<u32>) -> Self {
        let map = MapConfig::try_new(range)
            .ok()
            .map(|config| MapStorage::new(Blocking(flash), config, Cache::new_uncached()));
        SettingsStore { map }
    }

    /// The stored settings, if a valid record of this protocol version is there.
    pub fn load(&mut self) -> Option<DeviceSettings> {
        let map = self.map.as_mut()?;
        let mut buffer = [0u8; BUFFER_BYTES];
        let mut record = [0u8; MAX_FRAME_BYTES];
        let stored = run(map.fetch_item::<&[u8]>(&mut buffer, &SETTINGS_KEY))?.ok()??;
        let record = record.get_mut(..stored.len())?;
        record.copy_from_slice(stored);
        let settings: DeviceSettings = decode(record).ok()?;
        settings.validate().ok()?;
        Some(settings)
    }

    /// Stores `settings`; `false` if the flash refused.
    pub fn save(&mut self, settings: &DeviceSettings) -> bool {
        let Some(map) = self.map.as_mut() else {
            return false;
        };
        let mut frame = [0u8; MAX_FRAME_BYTES];
        let Ok(record) = encode(settings, &mut frame) else {
            return false;
        };
        let mut buffer = [0u8; BUFFER_BYTES];
        matches!(
            run(map.store_item(&mut buffer, &SETTINGS_KEY, &record)),
            Some(Ok(()))
        )
    }
}
