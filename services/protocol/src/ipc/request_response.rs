//! Request–response whose answer is a header plus a slice: [`SliceServer`] answers (as
//! on `map/get`), [`Ipc::request_slice`] asks.

#[cfg(doc)]
use super::IpcError;
use super::{Ipc, Result, Service, iox_err, node::retry_interrupted};
use crate::topics::{self, RequestResponse};
use iceoryx2::port::server::Server;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::request_response::PortFactory as RequestResponsePortFactory;
use std::fmt::Debug;

impl Ipc {
    /// Offers the request–response service `rr`: requests `Q`, responses a header `H`
    /// plus a slice of `T`. Poll it with [`SliceServer::answer`].
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the service or the server cannot be created.
    pub fn slice_server<Q, H, T>(&self, rr: &RequestResponse) -> Result<SliceServer<Q, H, T>>
    where
        Q: Debug + ZeroCopySend + 'static,
        H: Debug + ZeroCopySend + 'static,
        T: Debug + ZeroCopySend + Copy + 'static,
    {
        let server = self
            .request_response::<Q, H, T>(rr)?
            .server_builder()
            .initial_max_slice_len(rr.initial_slice_len)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(iox_err(format!("create server on {}", rr.name)))?;
        Ok(SliceServer {
            server,
            name: rr.name,
        })
    }

    /// Sends `request` to the request–response service `rr` and returns the first
    /// response (header and a copy of the slice).
    ///
    /// # Errors
    /// [`IpcError::Timeout`] when no server is there or none answers within the wait
    /// timeout, [`IpcError::Shutdown`] on a signal, [`IpcError::Iceoryx`] when sending or
    /// receiving fails.
    pub fn request_slice<Q, H, T>(&self, rr: &RequestResponse, request: Q) -> Result<(H, Vec<T>)>
    where
        Q: Debug + ZeroCopySend + 'static,
        H: Debug + ZeroCopySend + Copy + 'static,
        T: Debug + ZeroCopySend + Copy + 'static,
    {
        let service = self.request_response::<Q, H, T>(rr)?;
        let full = topics::service_name(&self.prefix, rr.name);
        self.wait_until(
            || format!("a server of {full}"),
            || service.dynamic_config().number_of_servers() > 0,
        )?;
        let client = service
            .client_builder()
            .create()
            .map_err(iox_err(format!("create client on {}", rr.name)))?;
        let pending = client
            .send_copy(request)
            .map_err(iox_err(format!("request on {}", rr.name)))?;
        self.wait_for(
            || format!("an answer from {full}"),
            || {
                let response = pending
                    .receive()
                    .map_err(iox_err(format!("response on {}", rr.name)))?;
                Ok(response.map(|r| (*r.user_header(), r.payload().to_vec())))
            },
        )
    }

    fn request_response<Q, H, T>(
        &self,
        rr: &RequestResponse,
    ) -> Result<RequestResponsePortFactory<Service, Q, (), [T], H>>
    where
        Q: Debug + ZeroCopySend + 'static,
        H: Debug + ZeroCopySend + 'static,
        T: Debug + ZeroCopySend + 'static,
    {
        let name = topics::service_name(&self.prefix, rr.name);
        let service_name =
            ServiceName::new(&name).map_err(iox_err(format!("service name {name}")))?;
        retry_interrupted(|| {
            self.node
                .service_builder(&service_name)
                .request_response::<Q, [T]>()
                .response_user_header::<H>()
                .open_or_create()
        })
        .map_err(iox_err(format!("open service {name}")))
    }
}

/// The server side of a request–response service whose responses are a header `H` plus
/// a slice of `T`; see [`Ipc::slice_server`].
pub struct SliceServer<Q, H, T>
where
    Q: Debug + ZeroCopySend + 'static,
    H: Debug + ZeroCopySend + 'static,
    T: Debug + ZeroCopySend + 'static,
{
    server: Server<Service, Q, (), [T], H>,
    name: &'static str,
}

impl<Q, H, T> SliceServer<Q, H, T>
where
    Q: Debug + ZeroCopySend + 'static,
    H: Debug + ZeroCopySend + Default + 'static,
    T: Debug + ZeroCopySend + Copy + 'static,
{
    /// Answers every pending request with what `respond` returns for it (without
    /// blocking); returns how many were answered. A client that left before its answer
    /// was sent is skipped.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when receiving a request or loaning the response fails.
    pub fn answer(&self, mut respond: impl FnMut(&Q) -> (H, Vec<T>)) -> Result<usize> {
        let mut n = 0;
        while let Some(request) = self
            .server
            .receive()
            .map_err(iox_err(format!("receive request on {}", self.name)))?
        {
            let (header, items) = respond(request.payload());
            let mut response = request
                .loan_slice_uninit(items.len())
                .map_err(iox_err(format!("loan response on {}", self.name)))?;
            *response.user_header_mut() = header;
            if let Err(e) = response.write_from_slice(&items).send() {
                tracing::debug!(error = ?e, "answer on {} not delivered", self.name);
            }
            n += 1;
        }
        Ok(n)
    }
}
